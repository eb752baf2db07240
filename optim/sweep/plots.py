"""Pictures of a sweep (PNG, written atomically next to results.csv):

* ``sweep.png``: every layout by name (best first, ranked like optim.sweep.best), its
  cycle time per move (robust: the worst case too) from the kinematic floor, the best
  layout of each move named in the title (left); cycle time against the first natural
  frequency, the best layouts marked (right);
* ``deviation.png``: deviation against time of every successful case of each move (grey),
  the best layout and the layout with the longest cycle highlighted (or, when every layout
  ties, the one with the largest peak deviation, and the title says they tie), with the
  threshold: the cases of equal model size are evaluated together (optim.sweep.evaluate).
"""

from __future__ import annotations

import numpy as np

from jaxflex.plots import deviation_axes, plt, save_figure
from jaxflex.response import as_move
from optim.sweep.best import best_layouts, objective_s, rank_key
from optim.sweep.evaluate import deviation_traces, group_by_size

MAX_TRACES = 200  # per move in deviation.png
MAX_ROWS = 30  # layouts named in sweep.png: the best MAX_ROWS - TAIL_ROWS and the worst
TAIL_ROWS = 5


def _ok_by_move(run) -> dict[str, list[tuple]]:
    """move name -> [(case, record)] of the successful cases, in the spec's order."""
    out: dict[str, list[tuple]] = {m.name: [] for m in run.spec.moves}
    for case in run.cases:
        record = run.records.get(case.case_id)
        if record is not None and record["status"] == "ok":
            out[case.move.name].append((case, record))
    return out


def _layout_order(by_move: dict[str, list[tuple]]) -> list[str]:
    """Layout names, best first by the first move that has results (then by the others)."""
    ranks: dict[str, list] = {}
    for items in by_move.values():
        for case, record in items:
            ranks.setdefault(case.layout.name, []).append(rank_key(record))
    return sorted(ranks, key=lambda name: ranks[name])


def _shown_rows(names: list[str]) -> list[str | None]:
    """The names drawn in sweep.png; None marks the gap where layouts are left out."""
    if len(names) <= MAX_ROWS:
        return list(names)
    head = MAX_ROWS - TAIL_ROWS
    return [*names[:head], None, *names[-TAIL_ROWS:]]


def plot_overview(run, path) -> None:
    by_move = {name: items for name, items in _ok_by_move(run).items() if items}
    rows = _shown_rows(_layout_order(by_move))
    bests = {b.move: b for b in best_layouts(run.spec, (i for v in by_move.values() for i in v))}
    height = max(4.5, 1.6 + 0.26 * len(rows))
    fig, (ax_rank, ax_freq) = plt.subplots(
        1, 2, figsize=(13, height), gridspec_kw={"width_ratios": [1.3, 1]}, layout="constrained"
    )
    y_of = {name: len(rows) - 1 - i for i, name in enumerate(rows) if name is not None}
    offsets = np.linspace(-0.18, 0.18, len(by_move)) if len(by_move) > 1 else [0.0]
    for (name, items), dy in zip(by_move.items(), offsets, strict=True):
        drawn = [(c, r) for c, r in items if c.layout.name in y_of]
        y = np.array([y_of[c.layout.name] for c, _ in drawn]) + dy
        cycle = np.array([r["opt"]["cycle_time_s"] for _, r in drawn])
        (line,) = ax_rank.plot(cycle, y, "o", ms=5, label=f"{name}: cycle time")
        color = line.get_color()
        worst = [r["opt"]["worst_cycle_time_s"] for _, r in drawn]
        if all(w is not None for w in worst):
            ax_rank.plot(worst, y, "v", ms=5, mfc="none", color=color, label=f"{name}: worst case")
        floor = items[0][1]["opt"]["kinematic_floor_s"]
        ax_rank.axvline(floor, color=color, ls="--", lw=0.8, label=f"{name}: kinematic floor")
        freq = np.array([r["fe"]["first_freq_hz"] for _, r in items])
        objective = np.array([objective_s(r) for _, r in items])
        ax_freq.plot(freq, objective, "o", ms=4, color=color, label=name)
        best = bests[name]
        found = next(r for c, r in items if c.layout.name == best.layout)
        ax_freq.plot(
            found["fe"]["first_freq_hz"], best.objective_s, "o", ms=11, mfc="none", color=color
        )
        ax_freq.annotate(
            f"best: {best.layout}",
            (found["fe"]["first_freq_hz"], best.objective_s),
            textcoords="offset points",
            xytext=(-8, 10),
            ha="right",
            fontsize=7,
            color=color,
        )
    labels = ["... " if name is None else name for name in rows]
    ax_rank.set_yticks(range(len(rows))[::-1], labels, fontsize=7)
    for tick, name in zip(ax_rank.get_yticklabels(), rows, strict=True):
        if any(b.layout == name for b in bests.values()):
            tick.set_fontweight("bold")
    ax_rank.set_ylim(-0.7, len(rows) - 0.3)
    ax_rank.set_xlabel("cycle time [s] (best layout of a move in bold)")
    left = len(_layout_order(by_move)) - sum(n is not None for n in rows)
    hidden = f"; {left} middle layouts not shown" if left else ""
    ax_rank.set_title(
        f"{run.spec.name}: {len(run.records)} cases, {run.n_errors} errors{hidden}", fontsize=10
    )
    what = "worst case" if any(b.objective == "worst case" for b in bests.values()) else "cycle"
    ax_freq.set_xlabel("first natural frequency [Hz]")
    ax_freq.set_ylabel(f"{what} [s]")
    ax_freq.set_title("\n".join(_best_title(b) for b in bests.values()), fontsize=9)
    for ax in (ax_rank, ax_freq):
        ax.grid(alpha=0.3)
        if ax.lines:
            ax.legend(fontsize=7, loc="best")
    save_figure(fig, path)


def _best_title(best) -> str:
    saving = best.baseline_s - best.objective_s
    versus = (
        f"{100 * saving / best.baseline_s:.0f} % vs {best.baseline}"
        if saving > 0
        else f"= {best.baseline}"
    )
    ties = f", {best.ties} tie" if best.ties else ""
    return f"{best.move}: best {best.layout} {best.objective_s:.3f} s ({versus}{ties})"


def plot_deviations(run, store, path, *, method: str = "batched") -> bool:
    """deviation.png from the stored models and moves; False if no case succeeded."""
    by_move = {k: v[:MAX_TRACES] for k, v in _ok_by_move(run).items() if v}
    if not by_move:
        return False
    dt_s = run.spec.optimization.dt_s
    threshold_m = run.spec.optimization.threshold_m
    fig, axes = plt.subplots(
        len(by_move), 1, figsize=(13, 3.4 * len(by_move)), squeeze=False, layout="constrained"
    )
    for ax, (name, items) in zip(axes[:, 0], by_move.items(), strict=True):
        horizon = 1.15 * max(r["opt"]["cycle_time_s"] for _, r in items) + dt_s
        models, moves = {}, {}
        for case, record in items:
            found = store.load_model(case.layout_id)
            if found is not None:
                models[case.case_id] = found[0]
                moves[case.case_id] = as_move(record["acc_m_s2"], dt_s)
        traces = {}
        for keys in group_by_size(models).values():
            t, d = deviation_traces(
                [models[k] for k in keys], [moves[k] for k in keys], horizon, method=method
            )
            traces.update(zip(keys, d, strict=True))
        # rank like optim.sweep.best: the optimised objective, ties by the peak deviation
        rank = {c.case_id: (rank_key(r), r, c) for c, r in items if c.case_id in traces}
        best = min(rank, key=lambda k: rank[k][0])
        worst = max(rank, key=lambda k: rank[k][0])
        all_tie = rank[best][0][0] == rank[worst][0][0]
        for key, d in traces.items():
            if key not in (best, worst):
                ax.plot(t, d * 1e3, color="0.75", lw=0.6)
        highlighted = [(best, "tab:green", "best")]
        if worst != best:
            label = "largest peak deviation" if all_tie else "longest cycle"
            highlighted.insert(0, (worst, "tab:red", label))
        for key, color, label in highlighted:
            _, record, case = rank[key]
            cyc = record["opt"]["cycle_time_s"]
            peak = record["opt"]["peak_deviation_m"] * 1e3
            ax.plot(
                t,
                traces[key] * 1e3,
                color=color,
                lw=1.3,
                label=f"{label}: {case.layout.name}, cycle {cyc:.3f} s, peak {peak:.3g} mm",
            )
            ax.axvline(cyc, color=color, ls=":", lw=1)
        deviation_axes(ax, threshold_m)
        tie = f", all at {rank[best][0][0]:.3f} s (ranked by peak deviation)" if all_tie else ""
        ax.set_title(f"move {name!r}: {len(traces)} layouts (optimised moves){tie}", fontsize=10)
        ax.set_ylabel("deviation [mm]")
        ax.legend(
            fontsize=8,
            title="dotted: cycle time",
            title_fontsize=8,
            loc="upper left",
            bbox_to_anchor=(1.01, 1.0),
        )
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
