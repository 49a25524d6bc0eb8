"""Figure helpers shared by the reports (matplotlib, Agg, no pyplot global
state): a figure with the report style, a fixed layout, saving, colour maps,
and the arm drawn in mm. Colours follow the paper: X red, Y blue, phi green.

Every report figure is at most :data:`MAX_WIDTH_IN` wide, so the HTML page
(its text column is about 1160 px) shows it at full size: nothing is shrunk
below the size its labels were set for. Layouts are fixed margins in inches
(:func:`place`), never measured from a figure's text, so equal inputs give
byte-identical PNGs whatever process draws them and in whatever order.
Maps never draw a value white on the white page: the diverging maps pass
through a light grey at zero (:func:`hue_cmap`), the sequential ones start
darker than the page (:func:`seq_cmap`), and unreachable configurations are
drawn as small crosses (:func:`mark_missing`), not as a colour.
"""

from __future__ import annotations

import io
import multiprocessing
import os
import sys
from concurrent.futures import ProcessPoolExecutor, as_completed
from typing import Callable, Dict, List, Optional, Tuple

import numpy as np
from matplotlib.backends.backend_agg import FigureCanvasAgg
from matplotlib.colors import LinearSegmentedColormap, LogNorm, Normalize
from matplotlib.figure import Figure

from ..files import check_path, write_bytes
from ..inputs import CdsmInputError
from ..progress import Progress
from ..robot import Robot

__all__ = ["DPI", "MAX_WIDTH_IN", "RED", "BLUE", "GREEN", "HUES", "NEGATIVE", "ZERO", "new_figure", "report_style",
           "save", "hue_cmap", "seq_cmap", "tension_cmap", "sym_norm", "chain_points", "draw_arm", "file_key",
           "place", "few_ticks", "colour_bar", "mark_missing", "png_bytes", "render_pngs", "render_jobs",
           "FigureJob"]

DPI = 110
#: Widest report figure, inches: MAX_WIDTH_IN * DPI = 1144 px fit the HTML text column unscaled.
MAX_WIDTH_IN = 10.4
RED, BLUE, GREEN = "#d62728", "#1f5fbf", "#2ca02c"
HUES = (RED, BLUE, GREEN)
#: The negative end of every diverging map (a hue no quantity uses) and its middle (zero: not the page's white).
NEGATIVE, ZERO = "#3f007d", "#c8c8c8"
# ``axes.titley`` fixed: titles sit just above the axes (no labels there),
# and matplotlib skips measuring every axis at each draw to place them
FONT = {"font.size": 10, "axes.titlesize": 10.5, "axes.labelsize": 10,
        "xtick.labelsize": 9, "ytick.labelsize": 9, "legend.fontsize": 9,
        "axes.titley": 1.0,
        # solid light grid lines: thin translucent ones vanished in the 256-colour PNGs but at their crossings
        "grid.color": "0.86", "grid.linewidth": 0.6, "grid.alpha": 1.0,
        # no mathtext: a robot's name such as "arm $1" is text, not a formula (a stray "$\" raised at draw time)
        "text.parse_math": False}


def new_figure(w: float, h: float) -> Figure:
    """A new Figure ``w`` x ``h`` inches with an Agg canvas (no pyplot
    state); ``w`` at most :data:`MAX_WIDTH_IN`."""
    if w > MAX_WIDTH_IN + 1e-9:
        raise ValueError(f"report figures are at most {MAX_WIDTH_IN} in wide, got {w}")
    with report_style():
        fig = Figure(figsize=(w, h), dpi=DPI)
    FigureCanvasAgg(fig)
    return fig


def place(fig: Figure, rows: int, cols: int, left: float = 0.75, right: float = 0.15, bottom: float = 0.55,
          top: float = 0.75, wgap: float = 0.9, hgap: float = 0.7) -> None:
    """Lay the ``rows`` x ``cols`` grid of ``fig`` out with fixed margins in
    inches: ``left``, ``right``, ``bottom``, ``top`` (the figure title's
    room) and the gaps between panels ``wgap``, ``hgap`` (room for a panel's
    colour bar and tick labels). Deterministic and free, unlike
    ``tight_layout``, which measures every label (and, cached per family,
    made a figure depend on which one was drawn first)."""
    w, h = fig.get_size_inches()
    aw = (w - left - right - (cols - 1) * wgap) / cols
    ah = (h - bottom - top - (rows - 1) * hgap) / rows
    if aw <= 0 or ah <= 0:
        raise ValueError(f"place: no room for a {rows} x {cols} grid in a {w} x {h} in figure")
    fig.subplots_adjust(left=left / w, right=1 - right / w, bottom=bottom / h, top=1 - top / h,
                        wspace=wgap / aw, hspace=hgap / ah)


def few_ticks(ax, n: int = 5) -> None:
    """At most about ``n`` major ticks per axis (a tick is one of the costliest
    artists to draw; the maps need no more)."""
    from matplotlib.ticker import MaxNLocator

    for axis in (ax.xaxis, ax.yaxis):
        if axis.get_scale() == "linear":
            axis.set_major_locator(MaxNLocator(n))


def colour_bar(fig: Figure, mappable, ax, label: str, ticks: int = 6):
    """A colour bar for ``mappable`` beside ``ax``, labelled ``label``, with
    about ``ticks`` major ticks. A log-scaled one gets plain numbers on every
    bar (matplotlib labels only decades, so a narrow range was left bare):
    round steps within about a decade, decades beyond; no minor ticks."""
    from matplotlib.ticker import FormatStrFormatter, LogLocator, MaxNLocator

    cb = fig.colorbar(mappable, ax=ax, shrink=0.92, pad=0.02)
    cb.set_label(label)
    norm = mappable.norm
    if isinstance(norm, LogNorm) and norm.vmax > 20 * norm.vmin:
        cb.locator = LogLocator(numticks=ticks + 1)
    else:
        cb.locator = MaxNLocator(ticks)
    if isinstance(norm, LogNorm):
        cb.formatter = FormatStrFormatter("%.3g")
        cb.minorticks_off()
    cb.update_ticks()
    return cb


def report_style():
    """The report fonts, for the duration of a ``with`` block."""
    import matplotlib

    return matplotlib.rc_context(FONT)


def png_bytes(fig: Figure, dpi: int = DPI) -> bytes:
    """``fig`` as PNG bytes with an adaptive palette of 256 colours: plots
    lose nothing visible and the files (and the self-contained HTML reports
    that embed them) shrink about four times. No metadata: equal figures
    give equal bytes."""
    from PIL import Image  # matplotlib's own dependency

    fig.set_dpi(dpi)
    fig.canvas.draw()
    w, h = fig.canvas.get_width_height(physical=True)
    img = Image.frombuffer("RGBA", (w, h), fig.canvas.buffer_rgba(), "raw", "RGBA", 0, 1).convert("RGB")
    buf = io.BytesIO()
    img.quantize(colors=256, method=Image.Quantize.FASTOCTREE, dither=Image.Dither.NONE).save(buf, format="PNG")
    return buf.getvalue()


def save(fig: Figure, path: "str | os.PathLike[str]", dpi: int = DPI) -> str:
    """Write ``fig`` as PNG (:func:`png_bytes`) at ``path`` (directories
    created), whole or not at all (:func:`cdsm.files.atomic_file`).
    Returns the path."""
    path = check_path(path, "figure file")
    os.makedirs(os.path.dirname(os.path.abspath(path)), exist_ok=True)
    return write_bytes(path, png_bytes(fig, dpi), "figure")


def hue_cmap(color: str) -> LinearSegmentedColormap:
    """Diverging map: negative :data:`NEGATIVE` (purple), zero :data:`ZERO`
    (light grey, visible on the white page), positive ``color``."""
    return LinearSegmentedColormap.from_list(f"div_{color}", [NEGATIVE, ZERO, color])


def tension_cmap() -> LinearSegmentedColormap:
    """Diverging map of tensions: negative (a cable would have to push) red,
    zero light grey, positive blue."""
    return LinearSegmentedColormap.from_list("tension", [RED, ZERO, BLUE])


def seq_cmap(name: str, start: float = 0.15) -> LinearSegmentedColormap:
    """The matplotlib map ``name`` without its first ``start`` of the range
    (``magma_r`` starts near white: its smallest values vanished on the page)."""
    import matplotlib

    base = matplotlib.colormaps[name]
    return LinearSegmentedColormap.from_list(f"{name}_from{start:g}", base(np.linspace(start, 1.0, 256)))


def mark_missing(ax, xy: np.ndarray, label: Optional[str] = None, size: float = 9.0) -> None:
    """Configurations without a value (unreachable, unsolved) at ``xy`` (K,
    2): small grey crosses under the map, never a colour of it."""
    if len(xy):
        ax.scatter(xy[:, 0], xy[:, 1], s=size, c="0.45", marker="x", linewidths=0.5, zorder=0, label=label,
                   rasterized=True)


def sym_norm(v: np.ndarray) -> Normalize:
    m = float(np.nanmax(np.abs(v))) if np.isfinite(v).any() else 1.0
    m = m if m > 0 else 1.0
    return Normalize(-m, m)


def chain_points(robot: Robot, theta) -> np.ndarray:
    """Points of the arm for drawing, m: theta (n,) rad -> (3n+1, 2).

    Row 0 is the base frame origin O_{0,b}; then for each linkage k = 1..n:
    joint k, the proximal face centre of disk k (O_{k,a}) and its distal face
    centre (O_{k,b}). The last row is the tip (equals ``robot.fk(theta)[:2]``).
    The heading of linkage k (after joint k) is sum(theta[:k]).
    """
    t = np.asarray(theta, dtype=np.float64).reshape(-1)
    if t.shape != (robot.n,):
        raise CdsmInputError(f"`theta`: expected shape ({robot.n},), got {np.shape(theta)}")
    lb, la, th = robot.link_before, robot.link_after, robot.thickness
    pts = [np.zeros(2)]
    p, head = np.zeros(2), 0.0
    for k in range(robot.n):
        p = p + lb[k] * np.array([np.cos(head), np.sin(head)])
        pts.append(p)
        head += t[k]
        d = np.array([np.cos(head), np.sin(head)])
        p = p + la[k] * d
        pts.append(p)
        p = p + th[k] * d
        pts.append(p)
    return np.array(pts)


def _hole_heights(robot: Robot) -> np.ndarray:
    """(n,) hole height of each upper cable at its own disk, m."""
    h = robot.holes
    return np.array([abs(h[2 * i, i + 1, 0, 1]) for i in range(robot.n)])


def draw_arm(ax, robot: Robot, theta, color: str, ls: str = "-", lw: float = 2.0,
             label: Optional[str] = None, disks: bool = True, alpha: float = 1.0) -> None:
    """Draw the arm at ``theta`` (n,) rad on ``ax`` in mm: links, joints (dots),
    disks (bars across the linkage, as wide as twice the hole height)."""
    pts = chain_points(robot, theta) * 1e3
    ax.plot(pts[:, 0], pts[:, 1], ls=ls, color=color, lw=lw, label=label, alpha=alpha,
            solid_capstyle="round")
    ax.plot(pts[1::3, 0], pts[1::3, 1], "o", color=color, ms=4, alpha=alpha)
    if disks:
        hh = _hole_heights(robot) * 1e3
        heads = np.cumsum(np.asarray(theta, float))
        base = np.array([0.0, 1.0]) * max(hh) * 1.05
        ax.plot([0, 0], [-base[1], base[1]], color="0.35", lw=4, solid_capstyle="butt")
        for k in range(robot.n):
            nrm = np.array([-np.sin(heads[k]), np.cos(heads[k])]) * hh[k] * 1.05
            for c in (pts[3 * k + 2], pts[3 * k + 3]):
                ax.plot([c[0] - nrm[0], c[0] + nrm[0]], [c[1] - nrm[1], c[1] + nrm[1]],
                        ls=ls, color=color, lw=1.4, alpha=alpha)



def file_key(key: str) -> str:
    """A scenario key as a file-name part: ``+`` -> ``plus``, ``-`` -> ``minus``."""
    return key.replace("+", "plus").replace("-", "minus")


# ---------------------------------------------------------------------------
# rendering a report's figures, in forked processes
# ---------------------------------------------------------------------------
#: One figure job: ``(name, make)``; ``make()`` returns ``[(file name, Figure)]``.
FigureJob = Tuple[str, Callable[[], List[Tuple[str, Figure]]]]

# what forked figure workers inherit: (jobs_of, study)
_FORKED: Optional[tuple] = None


def _render(make) -> Dict[str, bytes]:
    return {name: png_bytes(fig) for name, fig in make()}


def _die_with_parent(parent: int) -> None:
    """In a forked figure worker, first: end when the parent ends, however it
    ends (a signal, SIGKILL, the OOM killer). Linux's ``PR_SET_PDEATHSIG``
    has the kernel send SIGKILL when the thread that forked this process
    exits; a parent already gone ends the worker at once."""
    import ctypes
    import signal

    try:
        ctypes.CDLL(None, use_errno=True).prctl(1, int(signal.SIGKILL), 0, 0, 0)  # 1: PR_SET_PDEATHSIG
    except (OSError, AttributeError):
        pass
    if os.getppid() != parent:
        os._exit(1)


def _render_forked(i: int) -> Dict[str, bytes]:
    jobs_of, study = _FORKED
    return _render(jobs_of(study)[i][1])


def render_pngs(jobs_of: Callable[[object], List[FigureJob]], study, progress: bool = False,
                workers: Optional[int] = None) -> Dict[str, bytes]:
    """Render the figures ``jobs_of(study)`` (a list of :data:`FigureJob`,
    costliest first) to PNG bytes (:func:`png_bytes`); returns {name: PNG}
    in job order. ``workers`` processes render them (default: one per core;
    forked, so only where the platform forks — elsewhere one; each worker
    rebuilds the job list from the inherited study; they end with this
    process, however it ends). Shows a progress line when ``progress``."""
    global _FORKED
    jobs = jobs_of(study)
    n = (os.cpu_count() or 1) if workers is None else int(workers)
    fork = "fork" in multiprocessing.get_all_start_methods() and sys.platform.startswith("linux")
    bar = Progress(len(jobs), "figures", progress)
    out: Dict[str, Dict[str, bytes]] = {}
    if n > 1 and fork and len(jobs) > 1:
        _FORKED = (jobs_of, study)
        try:
            ctx = multiprocessing.get_context("fork")
            with ProcessPoolExecutor(min(n, len(jobs)), mp_context=ctx, initializer=_die_with_parent,
                                     initargs=(os.getpid(),)) as ex:
                futs = {ex.submit(_render_forked, i): name for i, (name, _) in enumerate(jobs)}
                for f in as_completed(futs):
                    out[futs[f]] = f.result()
                    bar.update(1)
        finally:
            _FORKED = None
    else:
        for name, make in jobs:
            out[name] = _render(make)
            bar.update(1)
    return {k: v for name, _ in jobs for k, v in out[name].items()}


def render_jobs(jobs_of: Callable[[object], List[FigureJob]], study, outdir: "str | os.PathLike[str]",
                progress: bool = False, workers: Optional[int] = None) -> Dict[str, str]:
    """Write the figures ``jobs_of(study)`` (:func:`render_pngs`) as
    ``outdir/<name>.png`` (created); returns {name: path} in job order."""
    outdir = check_path(outdir, "figure directory")
    try:
        os.makedirs(outdir, exist_ok=True)
    except OSError as exc:
        raise CdsmInputError(f"figure directory {outdir!r}: cannot create it ({exc.strerror})") from None
    return {name: write_bytes(os.path.join(outdir, f"{name}.png"), data, "figure")
            for name, data in render_pngs(jobs_of, study, progress=progress, workers=workers).items()}
