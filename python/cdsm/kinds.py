"""The arm's kind as data: :class:`Kind`, a string (``"planar"`` or
``"spatial"``) carrying the facts that differ between the kinds, so that the
rest of cdsm asks it instead of branching on its name.

A planar arm (``docs/model.md``) moves in the plane ``z = 0``: its task
vector is ``[x, y, phi]`` (m, m, rad; ``phi`` the end frame's angle about
``z``), its cables come in upper (position) and lower (force) pairs. A
spatial arm (``docs/spatial.md``) has the task ``[x, y, z, rx, ry, rz]``
(m, rad: the end frame's origin and rotation vector). Everything else below
follows from those two statements or is the words cdsm uses for them.

The numbers the core decides (how many Monte-Carlo quantities a planar study
returns, :data:`cdsm._cdsm.QUANTITIES`) are read from the core and checked
here once; the words (CSV column names, prose, figure layout) are
presentation and live here, one definition each. :func:`kind_of` is the one
lookup by name.
"""

from __future__ import annotations

from typing import Dict, Tuple

import numpy as np

from . import _cdsm
from .inputs import CdsmInputError, as_vector

__all__ = ["Kind", "KINDS", "kind_of", "PLANAR", "SPATIAL"]


class Kind(str):
    """An arm's kind: the string ``"planar"`` or ``"spatial"`` (so comparing
    it with its name, f-strings, JSON and dict keys keep working)
    with the facts of that kind as attributes.

    Geometry of the task (SI units): ``task_axes`` the names of the task
    vector's coordinates, ``task_units`` their units (``"m"``, ``"rad"``),
    ``dim`` how many of them are the position (2 or 3), ``rotation`` the
    attitude's form (``"angle"``: one angle about ``z``; ``"vector"``: the
    rotation vector), ``pose_words`` their words in prose.

    Solves: ``masks`` the pose-IK masks by name, each the core's argument
    (planar three weights on ``x, y, phi``; spatial the name itself);
    ``default_mask`` the mask the configuration choice matches targets on
    (:mod:`cdsm.accuracy.configurations`: planar ``"pose"``, spatial
    ``"position"``: the end origin, so an arm of more than three joints has
    a null space);
    ``mask_weights`` whether weights may be given instead of a name;
    ``target_arg`` and ``command_arg`` the kind's names of the IK targets and
    of the commanded cable lengths (in error messages); ``summed_angles``: a
    disk's attitude is the running sum of the joint angles (planar), so a
    row whose sum overflows is refused; ``pair_holes``: holes in the planar
    ``(2n, n+1, 2, 2)`` layout (cable, disk, face, (x, y)) rather than per
    cable; ``deviation_statics_on_moved_arm``: a single error scenario
    (:func:`cdsm.accuracy.scenarios.deviation`) judges the cables taut after
    the error on the arm with the moved holes (spatial) rather than on the
    nominal arm (planar, as cdsm 0.1).

    Statics: the task wrench is padded into the core's wrench
    (``core_wrench_rows`` of ``core_wrench_width``), the gravity into the
    core's 3-vector (:meth:`core_wrench`, :meth:`core_gravity`).

    Monte Carlo: ``quantities`` and ``quantity_units`` the columns of the
    statistics, ``norm`` the index of the position error's norm,
    ``norm_label`` / ``norm_short`` / ``norm_slug`` its words
    (``"|d(X, Y)|"``, ``"|dXY|"``, ``"dxy"``),
    ``default_samples`` the samples per configuration of a study.

    The study (``cdsm paper``, :mod:`cdsm.study`): ``hole_error_arg`` the
    argument a hole error is given by (``"dh"``: planar, one height error
    per disk; ``"dholes"``: spatial, every hole coordinate), the core's
    argument of the Monte Carlo too; ``hole_grouping`` the core's grouping
    of the hole errors (``"per_end_disk"``, ``"per_cable"``: the groups of
    ``CoreRobot.structure()``), ``hole_group`` a group's label (a format
    template over its 1-based index), ``hole_tolerance_key`` the key of the
    hole tolerances in a tolerance file (``cdsm tolerance --json``);
    ``pose_regions`` whether a region may be given as target poses
    (``poses:FILE.csv``, :func:`cdsm.accuracy.tolerance.parse_region`);
    ``hole_scenarios`` the single hole errors, each ``(error, key, label)``
    (``key`` and ``label`` format templates over ``cable``, ``disk``,
    ``size``); ``cable_scenario_label`` the label of a cable-length error;
    ``grid_protocols`` whether the paper's joint-grid protocols apply
    (else ``no_grid_reason`` says why not); ``singular`` the Jacobian rows
    of the singular measure (``"pose"``: the attitude row scaled by the
    straight length; ``"position"``).

    CSV columns of the study's tables: :attr:`pose_columns`,
    :attr:`tip_columns` (the position only) and ``csv`` = {table: ((column
    name, what it holds), ...)} for ``"scenarios"``, ``"mc_summary"`` (the
    kind's own columns of a protocol's Monte-Carlo summary) and
    ``"montecarlo"`` (``montecarlo.csv``) — the second a key the report's row
    builders know (:mod:`cdsm.report.study`; ``"max_abs:2"`` is the max
    ``|.|`` of task coordinate 2, ``"mean:4"`` the mean of quantity 4).
    ``report_tables`` = {table: ((header, cell), ...)} the report's tables
    that differ between the kinds (:mod:`cdsm.report.study`; a header is a
    template over ``q``, the position error's name; a cell names a column of
    the study's rows — ``"mm:a,b"`` / ``"deg:a/b"`` the columns in mm or deg
    joined by ``", "`` / ``" / "`` — or ``"protocol"``, ``"label_figure"``,
    ``"solved_of"``): ``"single_errors"`` and ``"mc_mean"`` (the mean signed
    deviation; none for a spatial arm).
    ``compensation`` the policy of :func:`cdsm.calibration.compensate`:
    ``shapes`` (the target shapes, in its error), ``ik_seed`` (the nominal
    IK's seed: ``"paper"``, the paper's seed, or ``"zeros"``),
    ``zero_rotation_first`` (targets without a rotation: the pose at
    rotation 0 first, the position alone where that fails — planar — or the
    position alone at once), ``unreachable`` and ``slack`` (flags; the
    second a template over ``min_tension``), ``position_error`` and
    ``rotation_error`` ((N, k) differences -> (N,) norms: the planar
    ``hypot`` and ``|dphi|``, else the 2-norm). ``cable_numbers``: results
    name the commanded cables by their numbers in the robot file (spatial;
    a planar arm's are upper cables 1..n). ``allocation`` the policy of
    :func:`cdsm.accuracy.tolerance.allocate`: ``equal_effect`` (the
    equal-effect shape: ``"per_error"``, the weight over each error's RMS
    effect in mm, or ``"per_group"``, over each group's root sum of squares,
    a group of no effect at the largest of the others) and ``weights`` (how
    many weights, a template over ``count``, ``m``, ``groups``, ``finite``);
    for ``cdsm tolerance``: ``region`` (the default ``--region``), ``robot``
    (the robot in its progress line), ``cables_line`` and ``holes_line``
    (the answer's lines, templates over ``cables``, the commanded cables'
    numbers, and ``groups``, the count of hole groups) and ``evaluations``
    (the Monte-Carlo evaluations in the last line, a template, "" for none).
    ``headline_aliases``: the extra names (cdsm 0.2's) of headline numbers,
    ``(alias, name)`` pairs, by where they are set (``"mc"``, ``"single"``).

    Figures and prose (:mod:`cdsm.report.study_figures`): ``figure`` the
    layout facts — ``projections`` (the maps on three orthogonal
    projections, the overviews on the main plane; else the one plane of the
    arm), ``equal`` (equal axis scales), ``ticks`` (ticks per axis),
    ``mc_wgap`` and ``row_wgap`` (gaps between panels, inches),
    ``rotation_overview`` (an overview of the rotation errors too),
    ``projection`` (matplotlib's, of a drawing's axes: None for 2-D),
    ``disk_angles`` (the angles, rad, about a face's normal at which a
    drawing samples its outline: a planar face is its diameter across the
    plane) and ``disk_lw`` (the outline's line width, points);
    ``words`` the phrases that differ: the error sources (``cables_per``,
    ``hole_group_each``,
    ``holes_per``, ``cables_every``, ``holes_every``), the Jacobian of the
    singular measure (``singular_of``), the overview's rows and columns
    (``overview_layout``) and the force cables' loads (``force_loads``, a
    template over ``grams``: their tensions as weights, g); in the report
    (:mod:`cdsm.report.study`) ``holes_each`` (the Monte Carlo's hole
    errors), ``force_row`` (the arm table's row of the force cables'
    tensions, "" for none), ``force_statics`` (their loads in the statics, a
    template over ``newtons``), ``hole_error`` and ``hole_pair`` (a hole
    error beside a length error), ``singular_rows`` (the Jacobian of the
    singular measure), ``workspace_caption`` (a template over
    ``attitude0``), ``scenario_caption`` (over ``label``, ``figure``,
    ``key``, ``q``), ``mc_caption`` and ``limit_notes`` (the kind's own
    limits of the study).
    """

    dim: int
    task_axes: Tuple[str, ...]
    task_units: Tuple[str, ...]
    rotation: str
    masks: Dict[str, object]
    default_mask: str
    mask_weights: bool
    mask_hint: str
    target_arg: str
    command_arg: str
    summed_angles: bool
    pair_holes: bool
    deviation_statics_on_moved_arm: bool
    core_wrench_rows: Tuple[int, ...]
    core_wrench_width: int
    quantities: Tuple[str, ...]
    quantity_units: Tuple[str, ...]
    default_samples: int
    hole_error_arg: str
    hole_grouping: str
    hole_group: str
    hole_tolerance_key: str
    pose_regions: bool
    hole_scenarios: Tuple[Tuple[str, str, str], ...]
    cable_scenario_label: str
    grid_protocols: bool
    no_grid_reason: str
    singular: str
    csv: Dict[str, Tuple[Tuple[str, str], ...]]
    report_tables: Dict[str, Tuple[Tuple[str, str], ...]]
    compensation: Dict[str, object]
    cable_numbers: bool
    allocation: Dict[str, str]
    headline_aliases: Dict[str, Tuple[Tuple[str, str], ...]]
    figure: Dict[str, object]
    words: Dict[str, str]

    def __new__(cls, name: str, **facts):
        kind = super().__new__(cls, name)
        kind.__dict__.update(facts)
        return kind

    def __reduce__(self):
        return kind_of, (str(self),)

    # ---- the task -----------------------------------------------------------
    @property
    def name(self) -> str:
        """The kind's name (the string itself)."""
        return str(self)

    @property
    def task(self) -> int:
        """Width of the task vector: 3 (planar) or 6 (spatial)."""
        return len(self.task_axes)

    @property
    def position_axes(self) -> Tuple[str, ...]:
        """The position coordinates' names (``("x", "y")`` or ``("x", "y", "z")``)."""
        return self.task_axes[:self.dim]

    @property
    def rotation_axes(self) -> Tuple[str, ...]:
        """The attitude coordinates' names (``("phi",)`` or ``("rx", "ry", "rz")``)."""
        return self.task_axes[self.dim:]

    @property
    def pose_columns(self) -> Tuple[str, ...]:
        """CSV names of the task coordinates with their units (``x_m``, ..., ``phi_rad``)."""
        return tuple(f"{a}_{u}" for a, u in zip(self.task_axes, self.task_units))

    @property
    def tip_columns(self) -> Tuple[str, ...]:
        """CSV names of the position coordinates (``x_m``, ``y_m``[, ``z_m``])."""
        return self.pose_columns[:self.dim]

    @property
    def hole_errors_per_coordinate(self) -> bool:
        """Whether a hole error is one hole coordinate's (spatial: ``dholes``,
        the core's ``holes`` sensitivities) rather than a coherent group's
        (planar: one disk's hole height, ``dh``, the core's ``pair``)."""
        return self.hole_error_arg == "dholes"

    # ---- the Monte Carlo's quantities ------------------------------------------
    @property
    def norm(self) -> int:
        """Index of the position error's norm among :attr:`quantities` (``dXY``, ``dXYZ``)."""
        return self.quantities.index("d" + "".join(a.upper() for a in self.position_axes))

    @property
    def norm_label(self) -> str:
        """The position error's norm in prose: ``|d(X, Y)|`` or ``|d(X, Y, Z)|``."""
        return "|d(" + ", ".join(a.upper() for a in self.position_axes) + ")|"

    @property
    def norm_short(self) -> str:
        """The position error's norm in a command's summary: ``|dXY|`` or ``|dXYZ|``."""
        return f"|{self.quantities[self.norm]}|"

    @property
    def norm_slug(self) -> str:
        """The position error's norm in file and column names: ``dxy`` or ``dxyz``."""
        return "d" + "".join(self.position_axes)

    # ---- arguments of the core --------------------------------------------------
    def require_pairs(self, name: str) -> None:
        """Raise :class:`CdsmInputError` naming ``name`` (an attribute of the
        planar description: link lengths, thickness and lower tension per
        joint) unless this kind's cables come in upper/lower pairs
        (:attr:`pair_holes`)."""
        if not self.pair_holes:
            raise CdsmInputError(f"`{name}`: available for planar arms only (this arm is {self})")

    def core_mask(self, mask):
        """The core's IK mask argument for ``mask`` (a name of :attr:`masks`,
        or task-width weights where :attr:`mask_weights`); anything else
        raises :class:`CdsmInputError` naming ``mask``."""
        if isinstance(mask, str) or not self.mask_weights:
            if not isinstance(mask, str) or mask not in self.masks:
                raise CdsmInputError(f"`mask`: expected one of {', '.join(map(repr, self.masks))}{self.mask_hint}, "
                                     f"got {mask!r}")
            value = self.masks[mask]
            return list(value) if self.mask_weights else value
        return [float(v) for v in as_vector("mask", mask, self.task)]

    def core_wrench(self, wrench: np.ndarray) -> np.ndarray:
        """(N, task) tip wrenches -> the core's (N, width) (the planar
        ``[Fx, Fy, Mz]`` as ``[Fx, Fy, 0, Mz]``), C-contiguous."""
        w = np.asarray(wrench, dtype=np.float64)
        if self.core_wrench_width == w.shape[1]:
            return w
        out = np.zeros((w.shape[0], self.core_wrench_width))
        out[:, list(self.core_wrench_rows)] = w
        return out

    def core_gravity(self, gravity) -> list:
        """Gravity ``(dim,)`` m/s^2 (checked, named ``gravity``) -> the core's
        3-vector (the plane's ``z`` component 0)."""
        g = [float(v) for v in as_vector("gravity", gravity, self.dim)]
        return g + [0.0] * (3 - self.dim)


def _scenario_columns(head, slug, axes, units, tail) -> Tuple[Tuple[str, str], ...]:
    """Columns of ``scenarios.csv``: ``head``, the RMS and max of the
    position norm (``slug``), the max ``|.|`` of each task coordinate of
    ``axes`` (with their ``units``), ``tail``."""
    return (tuple(head) + ((f"rms_{slug}_m", "rms_position"), (f"max_{slug}_m", "max_position"))
            + tuple((f"max_abs_d{a}_{u}", f"max_abs:{i}") for i, (a, u) in enumerate(zip(axes, units)))
            + tuple(tail))


def _core(kind: str) -> dict:
    """The facts the Rust core holds for ``kind`` (``rust/kinds.rs``,
    ``KindInfo``: one copy, the core's): dimension, task axes and units, the
    attitude's form, the Monte-Carlo quantities and units."""
    f = _cdsm.kind_info(kind)
    return dict(dim=int(f["dim"]), task_axes=tuple(f["task_axes"]), task_units=tuple(f["task_units"]),
                rotation=str(f["rotation"]), quantities=tuple(f["quantities"]),
                quantity_units=tuple(f["quantity_units"]), hole_grouping=str(f["hole_grouping"]))


PLANAR = Kind(
    "planar", **_core("planar"),
    masks={"pose": (1.0, 1.0, 1.0), "position": (1.0, 1.0, 0.0)}, default_mask="pose", mask_weights=True,
    mask_hint=" or 3 weights",
    target_arg="pose", command_arg="upper", summed_angles=True, pair_holes=True,
    deviation_statics_on_moved_arm=False,
    core_wrench_rows=(0, 1, 3), core_wrench_width=4,
    default_samples=1000,
    hole_error_arg="dh", hole_group="disk {}'s holes", hole_tolerance_key="hole_height_tol_m", pose_regions=True,
    hole_scenarios=(("hole", "disk{disk}", "{size:+g} mm on disk {disk}'s holes"),),
    cable_scenario_label="{size:+g} mm on cable {cable}", grid_protocols=True, no_grid_reason="", singular="pose",
    csv={"scenarios": _scenario_columns(
            (("scenario", "key"), ("label", "label"), ("figure", "figure"), ("protocol", "protocol"),
             ("configurations", "configurations"), ("solved", "solved"), ("unreachable", "unreachable"),
             ("no_solution_after_error", "no_solution")), "dxy", ("x", "y", "phi"), ("m", "m", "rad"),
            (("jump_points", "jump_points"), ("jump_edges", "jump_pairs"))),
         "mc_summary": (("max_abs_mean_dx_m", "max_abs_mean:0"), ("max_abs_mean_dy_m", "max_abs_mean:1"),
                        ("max_abs_mean_dphi_rad", "max_abs_mean:2")),
         "montecarlo": (("x_m", "tip:0"), ("y_m", "tip:1"), ("samples", "samples"), ("failed", "failed"),
                        ("mean_dx_m", "mean:0"), ("mean_dy_m", "mean:1"), ("mean_dphi_rad", "mean:2"),
                        ("mean_dxy_m", "mean:3"), ("p95_dxy_m", "p95"), ("max_dxy_m", "max:3"))},
    report_tables={"single_errors": (("scenario", "label_figure"), ("protocol", "protocol"), ("solved", "solved"),
                                     ("unreachable", "unreachable"), ("no solution after", "no_solution_after_error"),
                                     ("RMS {q} (mm)", "mm:rms_dxy_m"), ("max {q} (mm)", "mm:max_dxy_m"),
                                     ("max |dphi| (deg)", "deg:max_abs_dphi_rad"), ("jump points", "jump_points")),
                   "mc_mean": (("protocol", "protocol"), ("max |mean dX| (mm)", "mm:max_abs_mean_dx_m"),
                               ("max |mean dY| (mm)", "mm:max_abs_mean_dy_m"),
                               ("max |mean dphi| (deg)", "deg:max_abs_mean_dphi_rad"))},
    compensation=dict(shapes="(N, 3) or (N, 2)", ik_seed="paper", zero_rotation_first=True,
                      unreachable="unreachable: the nominal pose IK finds no configuration",
                      slack="slack cable: an upper cable tension <= {min_tension:g} N at the predicted configuration",
                      position_error=lambda d: np.hypot(d[:, 0], d[:, 1]), rotation_error=lambda d: np.abs(d[:, 0])),
    cable_numbers=False,
    allocation=dict(equal_effect="per_error", weights="2n = {count} positive{finite} numbers (n cables then n disks)",
                    region="grid:-30:30:5", robot="robot", cables_line="cable length tolerance (mm, per upper cable): ",
                    holes_line="hole height tolerance (mm, per disk):         ", evaluations=""),
    headline_aliases={"mc": (("mc_max_dxy_m", "mc_max_m"), ("mc_max_p95_dxy_m", "mc_max_p95_m")),
                      "single": (("worst_single_dxy_m", "worst_single_m"),)},
    figure=dict(projections=False, equal=False, ticks=4, mc_wgap=0.85, row_wgap=1.3, rotation_overview=False,
                projection=None, disk_angles=(np.pi, 0.0), disk_lw=3),
    words=dict(hole_group_each="one per disk's holes",
               cables_per="per upper cable", holes_per="per disk's holes", cables_every="every upper cable",
               holes_every="every disk's hole height",
               singular_of="pose Jacobian d[X, Y, L·phi]/dtheta (all joints zero loses X)",
               overview_layout="columns: cable −, cable +, disk −, disk +; rows: pairs 1..n",
               force_loads="lower weights {grams} g", holes_each="every disk's holes",
               force_row="lower-cable tensions", force_statics="the lower cables at {newtons} N",
               hole_error="hole error", hole_pair="holes of its pair",
               singular_rows="the pose Jacobian d[X, Y, L·phi]/dtheta (attitude row scaled by the straight length L)",
               workspace_caption="Workspace: the tips of the study's configurations{attitude0}; the straight arm in "
                                 "black.",
               scenario_caption="{label} ({figure}): dX red, dY blue, dphi green (negative purple, zero grey) over "
                                "the tip positions, one row per protocol; black rings: jump points; crosses: "
                                "unreachable or unsolved.",
               mc_caption="; mean signed dX (red), dY (blue), dphi (green)", limit_notes="",
               single_errors="Each single error: ±1 mm on one upper (position-controlled) cable, or ±0.35 mm on "
                             "one disk's holes (the hole height of its pair, on every face).",
               mean_note="The errors are symmetric about zero, so the mean signed deviation is much smaller than "
                         "the typical deviation: the maps show mean, 95th percentile and max of |d(X, Y)| as well.",
               rotation_error="predicted_phi_error",
               commands_note="L_i = nominal upper length at theta_cmd + dL_i; converged 1/0; flags empty when fine"))

SPATIAL = Kind(
    "spatial", **_core("spatial"), masks={"position": "position", "pointing": "pointing", "pose": "pose"},
    default_mask="position",
    mask_weights=False, mask_hint=" for a spatial arm", target_arg="target", command_arg="lengths", summed_angles=False,
    pair_holes=False, deviation_statics_on_moved_arm=True, core_wrench_rows=(0, 1, 2, 3, 4, 5), core_wrench_width=6,
    default_samples=200,
    hole_error_arg="dholes", hole_group="cable {}'s holes", hole_tolerance_key="hole_tol_m", pose_regions=False,
    hole_scenarios=(("radial", "radial{cable}", "{size:+g} mm radially on cable {cable}'s holes"),
                    ("normal", "normal{cable}", "{size:+g} mm along the disk normal on cable {cable}'s holes")),
    cable_scenario_label="{size:+g} mm on cable {cable}'s length", grid_protocols=False,
    no_grid_reason=("a spatial arm has no single attitude to hold over its workspace, and a joint grid is "
                    "impossible past a few joints: the errors are applied at configurations sampled in "
                    "the joint box (scrambled Sobol sequence); jump points are judged between nearest "
                    "neighbours in joint space"),
    singular="position",
    csv={"scenarios": _scenario_columns(
            (("scenario", "key"), ("label", "label"), ("protocol", "protocol"), ("kind", "error"), ("cable", "cable"),
             ("sign", "sign"), ("error_m", "size"), ("configurations", "configurations"), ("solved", "solved")),
            "dxyz", ("x", "y", "z"), ("m", "m", "m"),
            (("rms_rotation_rad", "rms_rotation"), ("max_rotation_rad", "max_rotation"),
             ("jump_points", "jump_points"), ("jump_pairs", "jump_pairs"),
             ("jump_points_near_singular", "near_singular_jumps"))),
         "mc_summary": (("max_mean_rotation_rad", "max_mean:4"),),
         "montecarlo": (("x_m", "tip:0"), ("y_m", "tip:1"), ("z_m", "tip:2"), ("samples", "samples"),
                        ("failed", "failed"), ("mean_dx_m", "mean:0"), ("mean_dy_m", "mean:1"),
                        ("mean_dz_m", "mean:2"), ("mean_dxyz_m", "mean:3"), ("p95_dxyz_m", "p95"),
                        ("max_dxyz_m", "max:3"), ("std_dxyz_m", "std:3"), ("mean_rotation_rad", "mean:4"),
                        ("max_rotation_rad", "max:4"))},
    report_tables={"single_errors": (("scenario", "scenario"), ("error", "label"), ("solved", "solved_of"),
                                     ("RMS {q} (mm)", "mm:rms_dxyz_m"), ("max {q} (mm)", "mm:max_dxyz_m"),
                                     ("max |dX|, |dY|, |dZ| (mm)", "mm:max_abs_dx_m,max_abs_dy_m,max_abs_dz_m"),
                                     ("RMS / max rotation (deg)", "deg:rms_rotation_rad/max_rotation_rad"),
                                     ("jump points", "jump_points")),
                   "mc_mean": ()},
    compensation=dict(shapes="(N, 3) or (N, 6) for a spatial arm", ik_seed="zeros", zero_rotation_first=False,
                      unreachable="unreachable: the nominal IK finds no configuration",
                      slack="slack cable: no tension set >= {min_tension:g} N holds the predicted configuration",
                      position_error=lambda d: np.linalg.norm(d, axis=1),
                      rotation_error=lambda d: np.linalg.norm(d, axis=1)),
    cable_numbers=True,
    allocation=dict(equal_effect="per_group",
                    weights="{count} positive{finite} numbers ({m} commanded cables then {groups} cables' "
                            "holes)",
                    region="sobol:1000", robot="spatial robot",
                    cables_line="cable length tolerance (mm, per commanded cable {cables}): ",
                    holes_line="hole tolerance (mm, every coordinate of each commanded cable's holes, cables "
                               "{cables}): ",
                    evaluations=" ({evaluations} Monte-Carlo evaluations)"),
    headline_aliases={"mc": (), "single": ()},
    figure=dict(projections=True, equal=True, ticks=3, mc_wgap=0.95, row_wgap=1.05, rotation_overview=True,
                projection="3d", disk_angles=tuple(np.linspace(0.0, 2.0 * np.pi, 48)), disk_lw=1),
    words=dict(hole_group_each="one per cable's holes",
               cables_per="per position cable", holes_per="per hole coordinate", cables_every="every position cable",
               holes_every="every coordinate of every hole",
               singular_of="position Jacobian (directions the arm never moves in left out)",
               overview_layout="rows: position cables; columns: ±1 mm length, ±0.35 mm holes radial, along the normal",
               force_loads="force cables at their set tension", holes_each="every hole coordinate", force_row="",
               force_statics="the force cables at their set tensions", hole_error="radial hole error",
               hole_pair="radial holes",
               singular_rows="the position rows of the geometric Jacobian (directions the arm can never move in are "
                             "left out)",
               workspace_caption="Workspace: the sampled tip positions on the x–y, x–z and y–z projections, coloured "
                                 "by the third coordinate (mm).",
               scenario_caption="{label} ({key}): {q} (top) and the rotation angle (bottom) on the three "
                                "projections; black rings: jump points.",
               mc_caption="; the 95th percentile on the other projections; histogram over every sample.",
               limit_notes="**Hole clearance** is an effect of the diagnosis library, not a manufacturing error "
                           "scenario of this study.",
               single_errors="Each single error: ±1 mm on a position-controlled cable's length; ±0.35 mm on all its "
                             "holes along the radius in each face plane (outward); ±0.35 mm on all its holes along "
                             "the disk normal. Holes of force-controlled cables do not move the tip of the rigid "
                             "model (their lengths are not commanded): no scenario of their own.",
               mean_note="", rotation_error="predicted_rotation_error",
               commands_note="L_i, dL_i: the i-th position-controlled cable (as dL_i in measurement files; "
                             "robot-file cables {cables}); L_i = nominal length at theta_cmd + dL_i; converged 1/0; "
                             "flags empty when fine"))

if len(PLANAR.quantities) != _cdsm.QUANTITIES:  # the core decides what a planar Monte Carlo returns
    raise ImportError(f"cdsm.kinds: the core's planar Monte Carlo returns {_cdsm.QUANTITIES} quantities, "
                      f"the planar kind names {len(PLANAR.quantities)}: rebuild the core")

#: The kinds by name.
KINDS: Dict[str, Kind] = {str(k): k for k in (PLANAR, SPATIAL)}


def kind_of(name: str) -> Kind:
    """The :class:`Kind` called ``name`` (``"planar"`` or ``"spatial"``);
    another name raises :class:`CdsmInputError`."""
    try:
        return KINDS[str(name)]
    except KeyError:
        raise CdsmInputError(f"`kind`: expected one of {', '.join(map(repr, KINDS))}, got {name!r}") from None
