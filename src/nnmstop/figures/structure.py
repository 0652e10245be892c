"""Frequency-energy figures of any structure (``paper_figures/tube_*`` for the tube), drawn from its datasets only.

``frequency_energy``: the regularized NNMs (stable solid, unstable dashed, branch points, folds and
resonance tongues passed marked), the exact NNM1, the linear frequencies (no contact; for a beam also
Euler-Bernoulli); ``shapes`` (finite-element beams): deformed shapes over half a period at the configured
energies; ``contact_force``: the stop force over a period at those energies; ``exact_vs_regularized``:
the relative frequency difference at matched energies; ``wear``: every branch's frequency and, at each stop, the wear
power and impact work rate of its orbits along the energy (:mod:`nnmstop.wear`); ``hole_shapes`` and
``hole_contact`` (a beam in circular holes): each branch's deformed shapes in both planes, and each plate's
contact point in its hole with its radial contact force.
"""

from __future__ import annotations

from types import SimpleNamespace

import numpy as np
from matplotlib.cm import ScalarMappable
from matplotlib.colors import LinearSegmentedColormap, Normalize
from matplotlib.patches import Rectangle

from nnmstop import fourier
from nnmstop.figures.common import label_minor_decades, save_figure

__all__ = ["STRUCTURE_FIGURES", "draw_structure_figure", "draw_study_figure", "point_at_energy", "branch_segments"]

REGULARIZED, EXACT = "tab:blue", "tab:red"
#: Colours of the deformed shapes from t = 0 (red) to T/2 (blue), with their colour bar.
SHAPE_COLORS = LinearSegmentedColormap.from_list("half_period", [(0.85, 0.3, 0.15), (0.15, 0.3, 0.85)])

#: A located point whose Jacobian's smallest singular value is below this fraction of the second
#: smallest is drawn as a branch point. A determinant sign change across a jump of the continuation
#: between two close curves leaves a located point with a ratio of order one, a branch point a small
#: one (how small depends on how well the bisection and projection resolve it).
SIMPLE_BRANCH_POINT_RATIO = 1e-2


def point_at_energy(energy, target: float) -> int:
    """Index of the stored point nearest (in log energy) to where the branch first reaches ``target``."""
    energy = np.asarray(energy, float)
    reached = np.flatnonzero(energy >= target)
    if reached.size == 0:
        raise ValueError(f"the branch never reaches energy {target!r} (highest {energy.max():.4g})")
    i = reached[0]
    if i > 0 and abs(np.log(energy[i - 1] / target)) < abs(np.log(energy[i] / target)):
        i -= 1
    return int(i)


def branch_segments(ds) -> np.ndarray:
    """Segment of every point of a branch dataset (0 throughout for a branch without tongues passed):
    each segment is its own curve, never joined by a line across a tongue."""
    return ds.segment.values


#: Where the shapes and contact forces are drawn when no energies are configured: fractions of NNM1's energy
#: range (in log energy), a scene that follows the branch.
ENERGY_FRACTIONS = (0.3, 0.6, 0.9)


def _energies(ds, spec) -> list:
    """The configured energies (``energies``), else those at :data:`ENERGY_FRACTIONS` of the branch's range."""
    if spec.get("energies"):
        return list(spec["energies"])
    low, high = float(ds.energy.min()), float(ds.energy.max())
    return [low ** (1 - r) * high**r for r in ENERGY_FRACTIONS]


def _line_segments(ax, x, y, stable, color, label):
    """Stable parts solid, unstable dashed; one legend entry."""
    stable = np.asarray(stable, bool)
    edges = np.flatnonzero(np.diff(stable.astype(int))) + 1
    for k, (a, b) in enumerate(zip(np.r_[0, edges], np.r_[edges, len(x)])):
        b = min(b + 1, len(x))
        ax.plot(x[a:b], y[a:b], color=color, lw=1.2, ls="-" if stable[a] else "--", label=label if k == 0 else None)


def _impact_labels(ax, ds):
    """The number of impacts per period (all stops) written where it changes along the branch."""
    impacts = ds.impacts_per_period.values
    starts = [0, *np.flatnonzero(np.diff(impacts)) + 1]
    for i in starts:
        ax.annotate(
            f"{int(impacts[i])}",
            (ds.energy.values[i], ds.frequency.values[i]),
            xytext=(0, 6),
            textcoords="offset points",
            fontsize=7,
            ha="center",
            color="0.25",
        )


def _passed_resonances(ax, ds, label_them: bool) -> None:
    """The tongues passed, marked (and, if ``label_them``, named with their n:1)."""
    if not ds.passed_resonance_frequency.size:
        return
    energy, frequency = ds.passed_resonance_energy.values, ds.passed_resonance_frequency.values
    ax.plot(energy, frequency, "v", color="tab:purple", ms=6, label="internal resonance passed (tongue)")
    if label_them:
        for e, f, n in zip(energy, frequency, ds.passed_resonance_harmonic.values):
            ax.annotate(
                f"{int(n)}:1", (e, f), xytext=(6, -10), textcoords="offset points", fontsize=7, color="tab:purple"
            )


def _feature_window(ds):
    """Energy window around NNM1's branch points, folds and tongues (None when it holds none)."""
    energies = np.concatenate([ds.branch_point_energy.values, ds.fold_energy.values, ds.passed_resonance_energy.values])
    if energies.size == 0:
        return None
    low, high = float(energies.min()) / 1.3, max(float(energies.max()), float(ds.energy.max())) * 1.05
    return low, high


def _located_points(ax, ds) -> None:
    """Branch points (a located point with a singular ratio of order one apart) and energy folds."""
    if ds.branch_point_energy.size:
        # a flagged step where the continuation jumped between two close curves changes the sign of
        # det [J; t^T] without a branch point: its located point has a singular ratio of order one
        simple = ds.branch_point_singular_ratio.values < SIMPLE_BRANCH_POINT_RATIO
        e, f = ds.branch_point_energy.values, ds.branch_point_frequency.values
        ax.plot(e[simple], f[simple], "kx", ms=6, label="branch point")
        if not simple.all():
            label = "sign change of det [J; t] without a branch point"
            ax.plot(e[~simple], f[~simple], "+", color="0.5", ms=6, label=label)
    if ds.fold_energy.size:
        ax.plot(ds.fold_energy.values, ds.fold_frequency.values, "o", mfc="none", mec="k", ms=5, label="energy fold")


def _linear_lines(ax, ds) -> None:
    """The branch's linear mode without contact (and the continuous beam's, for a beam)."""
    mode = int(ds.attrs["mode"])
    ax.axhline(float(ds.no_contact_frequency.sel(mode=mode)), color="0.4", lw=0.8, ls=":", label="linear, no contact")
    if "euler_bernoulli_frequency" in ds.attrs and mode <= np.size(ds.attrs["euler_bernoulli_frequency"]):
        analytical = float(np.atleast_1d(ds.attrs["euler_bernoulli_frequency"])[mode - 1])
        ax.axhline(analytical, color="0.4", lw=0.8, ls="-.", label="linear, Euler-Bernoulli")


def _branch_panel(ax, name, data, window=None) -> None:
    """One NNM: its segments (never joined across a tongue), marks, linear lines (the exact NNM1 with NNM1)."""
    ds = data[name]
    color = REGULARIZED if name == "nnm1" else "tab:green"
    segment = branch_segments(ds)
    for k in np.unique(segment):
        part = segment == k
        label = f"{name.upper()} regularized (H = {ds.attrs['harmonics']})" if k == segment[0] else None
        _line_segments(ax, ds.energy.values[part], ds.frequency.values[part], ds.stable.values[part], color, label)
    _impact_labels(ax, ds)
    _passed_resonances(ax, ds, label_them=window is not None or _feature_window(ds) is None)
    _located_points(ax, ds)
    _linear_lines(ax, ds)
    if name == "nnm1" and "exact" in data:
        _exact_curves(ax, data["exact"])
    ax.set_xscale("log")
    ax.set_xlabel("energy (nondimensional)")
    ax.set_ylabel("frequency (Hz of the nondimensional time)")
    if window is None:
        ax.set_title(f"{name.upper()}: dashed where unstable; numbers: impacts per period", fontsize=9)
        ax.legend(fontsize=7, loc="best")
        return
    inside = (ds.energy.values >= window[0]) & (ds.energy.values <= window[1])
    low, high = float(ds.frequency.values[inside].min()), float(ds.frequency.values[inside].max())
    pad = 0.06 * (high - low)
    ax.set_xlim(*window)
    ax.set_ylim(low - pad, high + pad)
    label_minor_decades(ax)
    ax.set_title(
        f"{name.upper()} enlarged where its branch points, folds and tongues lie (frame in the panel above); "
        "the parts before and after a tongue are separate curves",
        fontsize=9,
    )


def _frequency_energy(fig, data, spec):
    """One panel per NNM (their frequencies differ by a factor of about six), the exact NNM1 on the first;
    under them NNM1 enlarged where its marks crowd, if it has any."""
    names = sorted(name for name in data if name.startswith("nnm"))
    window = _feature_window(data["nnm1"]) if "nnm1" in data else None
    layout = [names] + ([["zoom"] * len(names)] if window else [])
    axes = fig.subplot_mosaic(layout)
    for name in names:
        _branch_panel(axes[name], name, data)
    if window:
        _branch_panel(axes["zoom"], "nnm1", data, window)
        (e0, e1), (f0, f1) = axes["zoom"].get_xlim(), axes["zoom"].get_ylim()
        frame = Rectangle((e0, f0), e1 - e0, f1 - f0, fill=False, ec="0.3", lw=0.8, ls=(0, (2, 1.5)), zorder=6)
        axes["nnm1"].add_patch(frame)
    fig.suptitle(f"{_structure_name(data[names[0]])}: frequency-energy plots", fontsize=10)


def _exact_curves(ax, exact):
    """The exact family: its backbone solid; the internal resonance it enters (if any) dotted and named; for a
    structure with no exact orbits (a circular clearance) a note that says why."""
    if exact.sizes["orbit"] == 0:
        ax.text(
            0.02,
            0.02,
            f"no exact orbits: {exact.attrs.get('end_reason', '')}"[:150],
            transform=ax.transAxes,
            fontsize=7,
            color=EXACT,
            va="bottom",
            wrap=True,
        )
        return
    resonant = exact.resonant_mode.values > 0 if "resonant_mode" in exact else np.zeros(exact.sizes["orbit"], bool)
    first = int(np.argmax(resonant)) if resonant.any() else len(resonant)
    e, f = exact.energy.values, exact.frequency.values
    ax.plot(e[: first + 1], f[: first + 1], color=EXACT, lw=1.2, label="NNM1 exact (non-smooth): backbone")
    if first < len(resonant):
        k, n = int(exact.resonant_mode.values[first]), int(exact.resonance_order.values[first])
        label = f"exact: {n}:1 resonance with mode {k} (energy into mode {k}, frequency locked)"
        ax.plot(e[first:], f[first:], color=EXACT, lw=1.0, ls=":", label=label)


def _orbit_samples(ds, i: int, samples: int):
    """q (dof, samples) and stop force (stop, samples) of point ``i`` over one period."""
    H = int(ds.attrs["harmonics"])
    q = fourier.to_time(fourier.from_cos_sin(ds.q_cos.values[i], ds.q_sin.values[i]), H, samples)
    f = fourier.to_time(fourier.from_cos_sin(ds.f_cos.values[i], ds.f_sin.values[i]), H, samples)
    return q, f


def _deflection(ds, q, s, plane: int = 1):
    """Deflection ``w / gap`` (``v / gap`` in the second ``plane`` of a beam bending in two) at positions ``s`` from
    DOF vectors ``q`` (..., dof) of a beam's branch dataset.

    A reduced structure's DOFs go through the dataset's ``recovery`` onto the full mesh's DOFs it keeps, whose
    nodes the Hermite shape functions then interpolate between."""
    from nnmstop.models.beam import beam_deflection

    if "recovery" in ds:
        q = np.asarray(q) @ ds.recovery.values.T
        labels = [str(v) for v in ds.recovered_dof_label.values]
        full_nodes = ds.recovered_dof_node.values
    else:
        labels = [str(v) for v in ds.dof_label.values]
        full_nodes = np.array([int(label.removeprefix("w").removeprefix("theta")) for label in labels])
    # the nodes the DOFs are on and both ends of the mesh (a constrained end has no DOF: w = 0 there), renumbered
    kept = np.union1d(full_nodes, [0, ds.sizes["node"] - 1])
    nodes = np.searchsorted(kept, full_nodes)
    coordinates = ds.node_coordinate.values[kept]
    shape = SimpleNamespace(dof_labels=labels, dof_nodes=nodes, node_coordinates=coordinates, n_dofs=len(labels))
    return beam_deflection(shape, q, s, plane)


def _stop_positions(ds) -> np.ndarray:
    """Position ``s / L`` of every stop of a beam's dataset (its mesh is uniform)."""
    return np.atleast_1d(ds.attrs["stop_nodes"]).astype(float) / float(ds.attrs["elements"])


def _shapes(fig, data, spec):
    ds = data["nnm1"]
    energies = _energies(ds, spec)
    s = np.linspace(0.0, 1.0, 401)
    axes = fig.subplots(1, len(energies), sharey=False, squeeze=False)[0]
    m = 2 * int(spec.get("shape_samples", 9) - 1)
    gaps = np.atleast_1d(ds.attrs["stop_gap_m"]) / float(ds.attrs["length_unit_m"])
    for ax, target in zip(axes, energies):
        i = point_at_energy(ds.energy.values, target)
        q, _ = _orbit_samples(ds, i, max(m, 2 * int(ds.attrs["harmonics"]) + 2))
        step = q.shape[1] // m
        w = _deflection(ds, q[:, : q.shape[1] // 2 + 1 : step].T, s)
        for wk, phase in zip(w, np.linspace(0.0, 0.5, len(w))):
            ax.plot(wk, s, color=SHAPE_COLORS(2.0 * phase), lw=0.9)
        for s_stop, gap in zip(_stop_positions(ds), gaps):
            ax.axhline(s_stop, color="0.6", lw=0.6)
            ax.plot([-gap, -gap], [s_stop - 0.03, s_stop + 0.03], "k-", lw=2)
            ax.plot([gap, gap], [s_stop - 0.03, s_stop + 0.03], "k-", lw=2)
        impacts = int(ds.impacts_per_period.values[i])
        ax.set_title(f"E = {ds.energy.values[i]:.3g} (nondim.), {impacts} impacts per period", fontsize=9)
        ax.set_xlabel("deflection w / gap")
    axes[0].set_ylabel("position s / L (foot at 0)")
    bar = fig.colorbar(ScalarMappable(Normalize(0.0, 0.5), SHAPE_COLORS), ax=list(axes), fraction=0.025)
    bar.set_label("instant t / T (half a period)")
    what = "stop" if int(ds.attrs["stops"]) == 1 else "stops"
    reduced = "; reduced orbits drawn on the full mesh" if "recovery" in ds else ""
    fig.suptitle(
        f"{_structure_name(ds)}, NNM1: deformed shapes over half a period\n({what}: black bars at ± gap{reduced})",
        fontsize=10,
    )


def _contact_force(fig, data, spec):
    """The force of every stop over one period at the configured energies: one panel per stop."""
    ds = data["nnm1"]
    stops = int(ds.attrs["stops"])
    axes = fig.subplots(1, stops, sharey=True, squeeze=False)[0]
    samples = 8 * int(ds.attrs["harmonics"]) + 8
    t = np.arange(samples) / samples
    places = _stop_positions(ds) if ds.attrs.get("structure") == "beam" else None
    for target in _energies(ds, spec):
        i = point_at_energy(ds.energy.values, target)
        _, f = _orbit_samples(ds, i, samples)
        for k, ax in enumerate(axes):
            ax.plot(t, f[k], lw=1.0, label=f"E = {ds.energy.values[i]:.3g} (nondim.)")
    for k, ax in enumerate(axes):
        ax.set_xlabel("instant t / T")
        label = ds.dof_label.values[ds.stop_dof.values[k]]
        where = f" at s / L = {places[k]:.3g}" if places is not None else f" on {label}"
        ax.set_title(f"stop {k + 1}{where}", fontsize=9)
    axes[0].set_ylabel("regularized stop force f (nondimensional)")
    axes[0].legend(fontsize=8)
    noun = "the stop" if stops == 1 else "each stop"
    fig.suptitle(f"{_structure_name(ds)}, NNM1: force of {noun} over one period", fontsize=10)


def _exact_vs_regularized(fig, data, spec):
    """Both NNM1 curves and their difference, over the energies of the exact family (where they compare)."""
    comparison, exact, nnm1 = data["comparison"], data["exact"], data["nnm1"]
    ax1, ax2 = fig.subplots(2, 1, sharex=True)
    _exact_curves(ax1, exact)
    none = exact.sizes["orbit"] == 0
    if none:  # nothing to compare: the regularized NNM1 alone, and the reason
        exact = nnm1
        ax2.text(0.5, 0.5, "no exact orbits: no comparison", transform=ax2.transAxes, ha="center", va="center")
    segment = branch_segments(nnm1)
    for k in np.unique(segment):
        part = segment == k
        label = "NNM1 regularized" if k == segment[0] else None
        ax1.plot(nnm1.energy.values[part], nnm1.frequency.values[part], color=REGULARIZED, label=label)
    low, high = float(exact.energy.min()), float(exact.energy.max())
    pad = 0.1 * max(np.log(high / low), np.log(2.0))
    window = (low * np.exp(-pad), high * np.exp(pad))
    inside = [
        ds.frequency.values[(ds.energy.values >= window[0]) & (ds.energy.values <= window[1])] for ds in (exact, nnm1)
    ]
    frequencies = np.concatenate(inside)
    spread = float(np.ptp(frequencies)) or 1e-3 * float(frequencies.max())
    ax1.set_ylim(frequencies.min() - 0.08 * spread, frequencies.max() + 0.08 * spread)
    ax1.set_xscale("log")
    ax1.set_xlim(*window)
    ax1.set_ylabel("frequency (Hz, nondim. time)")
    fig.legend(handles=ax1.get_legend_handles_labels()[0], loc="outside lower center", ncols=2, fontsize=8)
    difference = np.abs(comparison.relative_difference.values)
    ax2.plot(comparison.energy.values, difference, "o-", color="k", ms=3)
    finite = difference[np.isfinite(difference)]
    if finite.size and finite.min() > 0 and finite.max() / finite.min() > 10.0:
        ax2.set_yscale("log")
    unlike = (
        comparison.no_counterpart.values == 1 if "no_counterpart" in comparison else np.zeros(difference.size, bool)
    )
    if unlike.any():  # the energies where the regularized NNM1 is of another type: marked, not compared
        for e in comparison.energy.values[unlike]:
            ax2.axvline(e, color="0.75", lw=0.6, zorder=0)
        ax2.plot([], [], color="0.75", lw=0.6, label="no counterpart (regularized orbit of another type)")
        ax2.legend(fontsize=7, loc="best")
    ax2.set_xlabel("energy (nondimensional)")
    ax2.set_ylabel("|f_reg - f_exact| / f_exact")
    label_minor_decades(ax2)
    window_text = (
        "(no exact orbits for this structure: the regularized NNM1 alone)"
        if none
        else f"(drawn over the exact family's energies, {low:.3g} to {high:.3g}; the regularized branch goes on beyond)"
    )
    title = f"{_structure_name(nnm1)}, NNM1: exact against regularized at matched energies\n{window_text}"
    if int(comparison.attrs.get("skipped", 0)):
        title += f"\nnothing compared: {comparison.attrs['end_reason']}"
    fig.suptitle(title, fontsize=10)


#: Colours of the branches in the wear figure: planar NNMs blue, whirling ones orange (in order of their names).
WEAR_COLORS = {"nnm": ("tab:blue", "tab:green", "tab:purple"), "whirl": ("tab:orange", "tab:red", "tab:brown")}


#: Markers of the stops on the wear panel (the first stop's curves unmarked).
STOP_MARKERS = ("", "o", "s", "^", "v", "D")

#: The wear panel's lower limit, relative to its largest value: a whirl's impact work rate is zero up to round-off
#: of the stored contact energy, which a log axis would otherwise stretch over many decades.
WEAR_DECADES_SHOWN = 1e-4


def _branch_color(name: str) -> str:
    family = "whirl" if name.startswith("whirl") else "nnm"
    number = int("".join(c for c in name if c.isdigit()) or 1)
    colors = WEAR_COLORS[family]
    return colors[(number - 1) % len(colors)]


def _branch_label(name: str, ds) -> str:
    motion = "whirling" if ds.attrs.get("motion", "planar") == "whirl" or name.startswith("whirl") else "planar"
    return f"{name} ({motion}, H = {ds.attrs['harmonics']})"


def _wear(fig, data, spec):
    """Every branch of the scene (planar and whirling) along energy: its frequency (dashed where unstable), then at
    each stop the wear power <|F_N| v_t> (solid) and the impact work rate (dotted) of its orbits, on a log scale
    where they are positive (an orbit that touches no stop has neither; planar motion wears by impacts only)."""
    names = sorted(data)
    if not names:
        raise ValueError("the wear figure needs at least one branch dataset")
    missing = [name for name in names if "wear_power" not in data[name]]
    if missing:
        raise ValueError(f"branch datasets {missing} have no wear variables (written before nnmstop.wear)")
    top, bottom = fig.subplots(2, 1, sharex=True)
    curves = []  # (energy, value, colour, style, stop, label) of every positive wear quantity
    for name in names:
        ds = data[name]
        color, label = _branch_color(name), _branch_label(name, ds)
        energy = ds.energy.values
        _line_segments(top, energy, ds.frequency.values, ds.stable.values, color, label)
        for k, stop in enumerate(ds.stop.values):
            suffix = f", stop {int(stop) + 1}" if ds.sizes["stop"] > 1 else ""
            for variable, style, what in (("wear_power", "-", "wear power"), ("impact_work_rate", ":", "impact work")):
                value = ds[variable].values[:, k]
                if (value > 0).any():
                    curves.append(
                        (energy, np.where(value > 0, value, np.nan), color, style, k, f"{name}{suffix}: {what}")
                    )
    largest = max((float(np.nanmax(curve[1])) for curve in curves), default=0.0)
    drawn = [curve for curve in curves if np.nanmax(curve[1]) >= WEAR_DECADES_SHOWN * largest]
    for energy, value, color, style, k, label in drawn:  # a branch's stops told apart by their markers
        marker = STOP_MARKERS[k % len(STOP_MARKERS)]
        bottom.plot(energy, value, color=color, ls=style, lw=1.2, marker=marker, markevery=0.08, ms=4, label=label)
    top.set_xscale("log")
    top.set_ylabel("frequency (Hz of the nondimensional time)")
    top.set_title("frequency along each branch (dashed where unstable)", fontsize=9)
    top.legend(fontsize=7, loc="best")
    bottom.set_xlabel("energy (nondimensional)")
    bottom.set_ylabel("power (nondimensional: k0 L0^2 / T0)")
    if drawn:
        bottom.set_yscale("log")
        bottom.set_ylim(WEAR_DECADES_SHOWN * largest, 2.0 * largest)
        bottom.legend(fontsize=7, loc="best")
    else:
        bottom.text(0.5, 0.5, "no orbit touches a stop", transform=bottom.transAxes, ha="center", fontsize=8)
    bottom.set_title(
        "at each stop (marked by stop): wear power <|F_N| v_t> (solid) and impact work rate <(F_N v_N)+> (dotted)\n"
        f"planar motion does not slide, a whirl does not impact; curves below {WEAR_DECADES_SHOWN:g} x the largest "
        "(round-off) not drawn",
        fontsize=9,
    )
    fig.suptitle(f"{_structure_name(data[names[0]])}: branches and the wear of the stops", fontsize=10)


def _hole_energies(ds, name: str, spec) -> list:
    """The configured energies (``energies``) a branch reaches, each drawn at the point nearest to it."""
    reached = [e for e in spec["energies"] if e <= float(ds.energy.values.max())]
    if not reached:
        raise ValueError(
            f"branch {name} reaches energy {float(ds.energy.values.max()):.4g}, below every configured figure energy "
            f"{list(spec['energies'])}"
        )
    return reached


def _hole_orbit(ds, i: int, samples: int):
    """``(x, y, radial force)`` of every circular stop of point ``i`` over one period: the stop's two displacements
    over its gap (``(stop, samples)`` each) and the magnitude of its regularized force."""
    H = int(ds.attrs["harmonics"])
    q, f = _orbit_samples(ds, i, samples)
    f2 = fourier.to_time(fourier.from_cos_sin(ds.f2_cos.values[i], ds.f2_sin.values[i]), H, samples)
    gaps = ds.stop_gap.values[:, None]
    return q[ds.stop_dof.values] / gaps, q[ds.stop_other_dof.values] / gaps, np.hypot(f, f2)


def _circular_stops(data) -> list:
    names = sorted(data)
    flat = [name for name in names if "f2_cos" not in data[name] or "stop_other_dof" not in data[name]]
    if not names or flat:
        raise ValueError(f"the hole figures draw branches of a structure in circular holes, got {flat or 'none'}")
    return names


def _hole_shapes(fig, data, spec):
    """Each branch (a row): the deformed tube in both planes over half a period at the largest configured energy it
    reaches, drawn on the full mesh (the holes' diameters as black bars at each plate)."""
    names = _circular_stops(data)
    axes = fig.subplots(len(names), 2, sharey=True, squeeze=False)
    m = 2 * int(spec.get("shape_samples", 9) - 1)
    s = np.linspace(0.0, 1.0, 401)
    for row, name in zip(axes, names):
        ds = data[name]
        i = point_at_energy(ds.energy.values, _hole_energies(ds, name, spec)[-1])
        q, _ = _orbit_samples(ds, i, m * (1 + (2 * int(ds.attrs["harmonics"]) + 1) // m))
        instants = q[:, : q.shape[1] // 2 + 1 : q.shape[1] // m].T
        gaps = np.atleast_1d(ds.attrs["stop_gap_m"]) / float(ds.attrs["length_unit_m"])
        for plane, ax in zip((1, 2), row):
            for shape, phase in zip(_deflection(ds, instants, s, plane), np.linspace(0.0, 0.5, len(instants))):
                ax.plot(shape, s, color=SHAPE_COLORS(2.0 * phase), lw=0.9)
            for s_stop, gap in zip(_stop_positions(ds), gaps):
                ax.axhline(s_stop, color="0.6", lw=0.6)
                for side in (-gap, gap):
                    ax.plot([side, side], [s_stop - 0.03, s_stop + 0.03], "k-", lw=2)
            ax.set_title(f"{_branch_label(name, ds)}, E = {ds.energy.values[i]:.3g}: plane {plane}", fontsize=9)
            ax.set_xlabel(f"deflection {'w' if plane == 1 else 'v'} / gap")
        row[0].set_ylabel("position s / L (foot at 0)")
    bar = fig.colorbar(ScalarMappable(Normalize(0.0, 0.5), SHAPE_COLORS), ax=list(axes.ravel()), fraction=0.025)
    bar.set_label("instant t / T (half a period)")
    fig.suptitle(
        f"{_structure_name(data[names[0]])}: deformed shapes in both planes\n(plates: the hole's diameter in black;"
        " reduced orbits drawn on the full mesh)",
        fontsize=10,
    )


def _hole_contact(fig, data, spec):
    """Each branch (two rows): the orbit of every plate's contact point in its hole (the clearance circle drawn) and
    the magnitude of its radial contact force over one period, at each configured energy the branch reaches."""
    names = _circular_stops(data)
    stops = int(data[names[0]].attrs["stops"])
    axes = fig.subplots(2 * len(names), stops, squeeze=False)
    circle = np.linspace(0.0, 2.0 * np.pi, 361)
    for k, name in enumerate(names):
        ds = data[name]
        samples = 8 * int(ds.attrs["harmonics"]) + 8
        t = np.arange(samples + 1) / samples
        places = _stop_positions(ds)
        for i in sorted({point_at_energy(ds.energy.values, target) for target in _hole_energies(ds, name, spec)}):
            x, y, force = _hole_orbit(ds, i, samples)
            label = f"E = {ds.energy.values[i]:.3g}"
            for j in range(stops):
                axes[2 * k, j].plot(np.append(x[j], x[j, 0]), np.append(y[j], y[j, 0]), lw=1.0, label=label)
                axes[2 * k + 1, j].plot(t, np.append(force[j], force[j, 0]), lw=1.0, label=label)
        for j in range(stops):
            orbit, radial = axes[2 * k, j], axes[2 * k + 1, j]
            orbit.plot(np.cos(circle), np.sin(circle), color="k", lw=1.2)
            orbit.set_aspect("equal", adjustable="datalim")
            orbit.set_title(f"{name}: plate {j + 1} at s / L = {places[j]:.3g}", fontsize=8)
            orbit.set_xlabel("x / gap", fontsize=8)
            radial.set_xlabel("instant t / T", fontsize=8)
        axes[2 * k, 0].set_ylabel("y / gap (circle: the clearance)", fontsize=8)
        axes[2 * k + 1, 0].set_ylabel("|F| radial (nondim.)", fontsize=8)
        axes[2 * k + 1, 0].legend(fontsize=7, title=_branch_label(name, ds), title_fontsize=7)
    fig.suptitle(
        f"{_structure_name(data[names[0]])}: each plate's contact point in its hole and its radial contact force",
        fontsize=10,
    )


STRUCTURE_FIGURES = {
    "frequency_energy": (_frequency_energy, (11.0, 9.0)),
    "shapes": (_shapes, (10.0, 4.5)),
    "contact_force": (_contact_force, (10.0, 4.0)),
    "exact_vs_regularized": (_exact_vs_regularized, (7.5, 6.8)),
    "wear": (_wear, (8.5, 7.5)),
    "hole_shapes": (_hole_shapes, (9.0, 8.0)),
    "hole_contact": (_hole_contact, (10.0, 11.0)),
}


def _structure_name(ds) -> str:
    kind = ds.attrs.get("structure", "matrices")
    stops = f"{int(ds.attrs['stops'])} stop(s)"
    if "stop_kind" in ds:  # not all the paper's bilateral stop: say which
        stops = f"{int(ds.attrs['stops'])} stop(s): {', '.join(str(k).replace('_', '-') for k in ds.stop_kind.values)}"
    dofs = f"{int(ds.attrs['dofs'])} DOF"
    if "full_dofs" in ds.attrs:
        dofs = f"{int(ds.attrs['full_dofs'])} DOF reduced to {int(ds.attrs['dofs'])}"
    if kind == "beam":
        return f"Beam with {stops} ({dofs})"
    if "full_dofs" in ds.attrs:
        return f"Structure of {dofs} with {stops}"
    return f"{int(ds.attrs['dofs'])}-DOF structure with {stops}"


def draw_structure_figure(name: str, data: dict, spec: dict, pdf_path) -> None:
    """Draw figure ``name`` from the datasets ``data`` (keys nnm1, nnm2, exact, comparison as needed)."""
    import matplotlib.pyplot as plt

    if name not in STRUCTURE_FIGURES:
        raise ValueError(f"structure figure must be one of {sorted(STRUCTURE_FIGURES)}, got {name!r}")
    draw, size = STRUCTURE_FIGURES[name]
    fig = plt.figure(figsize=size, layout="constrained")
    try:
        draw(fig, data, spec)
    except Exception:
        plt.close(fig)
        raise
    save_figure(fig, pdf_path, spec["png_dpi"])


def draw_study_figure(cases: list, spec: dict, pdf_path) -> None:
    """NNM1 backbones of the study cases: physical frequency against the largest displacement at the plate."""
    import matplotlib.pyplot as plt

    fig, ax = plt.subplots(figsize=(7.0, 5.0), layout="constrained")
    factors = sorted({float(ds.attrs["study_stiffness_factor"]) for ds in cases})
    gaps = sorted({float(ds.attrs["study_gap_m"]) for ds in cases})
    styles = ["-", "--", ":", "-."]
    for ds in cases:
        factor, gap = float(ds.attrs["study_stiffness_factor"]), float(ds.attrs["study_gap_m"])
        color = plt.cm.viridis(factors.index(factor) / max(1, len(factors) - 1))
        hz = ds.frequency.values * float(ds.attrs["angular_frequency_unit_rad_per_s"])
        ax.plot(
            ds.x_max.values * gap * 1e3,
            hz,
            color=color,
            ls=styles[gaps.index(gap) % len(styles)],
            label=f"k = {factor:g} x 3EI/a^3, gap = {gap * 1e3:g} mm",
        )
    ax.set_xscale("log")
    ax.set_xlabel("largest displacement at the plate (mm, physical)")
    ax.set_ylabel("frequency (Hz, physical time)")
    harmonics = sorted({int(ds.attrs["harmonics"]) for ds in cases})
    ax.set_title(
        f"Tube NNM1 over gap and plate stiffness (regularized, H = {', '.join(map(str, harmonics))})\n"
        "in physical units, unlike the other tube figures: x_max x gap, frequency x the time unit's rad/s",
        fontsize=9,
    )
    ax.legend(fontsize=7)
    save_figure(fig, pdf_path, spec["png_dpi"])
