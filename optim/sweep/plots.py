"""Pictures of a sweep (PNG, written atomically next to results.csv):

* ``sweep.png``: cycle time of every layout, sorted, per move, with the kinematic floor
  (left), and cycle time against the first natural frequency (right);
* ``deviation.png``: deviation against time of every successful case of each move (grey),
  the best and the worst layout highlighted, with the threshold: the cases of equal model
  size are evaluated together (optim.sweep.evaluate).
"""

from __future__ import annotations

import numpy as np

from jaxflex.plots import plt, save_figure
from optim.sweep.evaluate import deviation_traces, group_by_size

MAX_TRACES = 200  # per move in deviation.png


def _ok_by_move(run) -> dict[str, list[tuple]]:
    """move name -> [(case, record)] of the successful cases, in the spec's order."""
    out: dict[str, list[tuple]] = {m.name: [] for m in run.spec.moves}
    for case in run.cases:
        record = run.records.get(case.case_id)
        if record is not None and record["status"] == "ok":
            out[case.move.name].append((case, record))
    return out


def plot_overview(run, path) -> None:
    by_move = _ok_by_move(run)
    fig, (ax_rank, ax_freq) = plt.subplots(1, 2, figsize=(12, 4.5))
    for name, items in by_move.items():
        if not items:
            continue
        cycle = np.array([r["opt"]["cycle_time_s"] for _, r in items])
        freq = np.array([r["fe"]["first_freq_hz"] for _, r in items])
        order = np.argsort(cycle, kind="stable")
        (line,) = ax_rank.plot(np.arange(1, len(items) + 1), cycle[order], "o-", ms=3, label=name)
        floor = items[0][1]["opt"]["kinematic_floor_s"]
        ax_rank.axhline(floor, color=line.get_color(), ls="--", lw=0.8)
        worst = [r["opt"]["worst_cycle_time_s"] for _, r in items]
        if all(w is not None for w in worst):
            ax_rank.plot(
                np.arange(1, len(items) + 1),
                np.array(worst)[order],
                "v",
                ms=3,
                mfc="none",
                color=line.get_color(),
                label=f"{name}: robust worst case",
            )
        ax_freq.plot(freq, cycle, "o", ms=4, color=line.get_color(), label=name)
    n_err = run.n_errors
    ax_rank.set_xlabel("layout rank (by cycle time)")
    ax_rank.set_ylabel("cycle time [s] (dashed: kinematic floor)")
    ax_rank.set_title(f"{run.spec.name}: {len(run.records)} cases, {n_err} errors")
    ax_freq.set_xlabel("first natural frequency [Hz]")
    ax_freq.set_ylabel("cycle time [s]")
    for ax in (ax_rank, ax_freq):
        ax.grid(alpha=0.3)
        if ax.lines:
            ax.legend(fontsize=8)
    save_figure(fig, path)


def plot_deviations(run, store, path, *, method: str = "batched") -> bool:
    """deviation.png from the stored models and moves; False if no case succeeded."""
    by_move = {k: v[:MAX_TRACES] for k, v in _ok_by_move(run).items() if v}
    if not by_move:
        return False
    dt_s = run.spec.optimization.dt_s
    threshold_m = run.spec.optimization.threshold_m
    fig, axes = plt.subplots(len(by_move), 1, figsize=(9, 3.2 * len(by_move)), squeeze=False)
    for ax, (name, items) in zip(axes[:, 0], by_move.items(), strict=True):
        horizon = 1.15 * max(r["opt"]["cycle_time_s"] for _, r in items) + dt_s
        models, accs = {}, {}
        for case, record in items:
            found = store.load_model(case.layout_id)
            if found is not None:
                models[case.case_id] = found[0]
                accs[case.case_id] = np.asarray(record["acc_m_s2"])
        traces = {}
        for keys in group_by_size(models).values():
            t, d = deviation_traces(
                [models[k] for k in keys], [accs[k] for k in keys], dt_s, horizon, method=method
            )
            traces.update(zip(keys, d, strict=True))
        # rank by cycle time, ties by the peak deviation during the move
        rank = {
            c.case_id: (r["opt"]["cycle_time_s"], r["opt"]["peak_deviation_m"], c)
            for c, r in items
            if c.case_id in traces
        }
        best = min(rank, key=lambda k: rank[k][:2])
        worst = max(rank, key=lambda k: rank[k][:2])
        for key, d in traces.items():
            if key not in (best, worst):
                ax.plot(t, d * 1e3, color="0.75", lw=0.6)
        highlighted = ((worst, "tab:red", "worst"), (best, "tab:green", "best"))
        for key, color, label in highlighted[1:] if best == worst else highlighted:
            cyc, _, case = rank[key]
            ax.plot(
                t,
                traces[key] * 1e3,
                color=color,
                lw=1.3,
                label=f"{label}: {case.layout.name}, cycle {cyc:.3f} s",
            )
            ax.axvline(cyc, color=color, ls=":", lw=1)
        ax.axhline(
            threshold_m * 1e3, color="k", ls="--", lw=1, label=f"threshold {threshold_m * 1e3:g} mm"
        )
        ax.set_title(f"move {name!r}: {len(traces)} layouts (optimised moves)")
        ax.set_ylabel("deviation [mm]")
        ax.set_yscale("log")
        ax.set_ylim(bottom=threshold_m * 1e3 / 100)
        ax.grid(alpha=0.3, which="both")
        ax.legend(fontsize=8)
    axes[-1, 0].set_xlabel("time [s]")
    save_figure(fig, path)
    return True


def plot_sweep(run, store) -> list[str]:
    """Write sweep.png and deviation.png into the results directory; their paths."""
    if not any(r["status"] == "ok" for r in run.records.values()):
        return []
    paths = [store.root / "sweep.png"]
    plot_overview(run, paths[0])
    if plot_deviations(run, store, store.root / "deviation.png"):
        paths.append(store.root / "deviation.png")
    return [str(p) for p in paths]
