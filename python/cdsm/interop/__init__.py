"""Other tools' robot descriptions (``docs/interop.md``): CASPR's models in
(:meth:`cdsm.Robot.from_caspr`, :mod:`.caspr`), OpenCR-MuJoCo's continuum
robots and recordings in (:mod:`.opencr`), MuJoCo's MJCF
(:meth:`cdsm.Robot.to_mjcf`, :mod:`.mjcf`) and URDF
(:meth:`cdsm.Robot.to_urdf`, :mod:`.urdf`) out, the last two over the same
chain of bodies (:mod:`.chain`). SI units."""
