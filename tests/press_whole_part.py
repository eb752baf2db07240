"""The README's press move checked on the whole part, independently of the certificate
(docs/optim.md, "The README's command on the whole part"): not a test (it takes about 5 min
of CPU), a command to rerun on a result directory of the README's press command:

    python tests/press_whole_part.py RESULT_DIR

The distance by tests/independent.py alone (every FE node of the built-in plate, both skins,
a 0.1 ms grid to 4 s after the move, 60 modes by scipy's lsim, the sag by a direct FE solve);
the cups (safety 1.5) and the von Mises stress by lsim through the 60-mode model's output maps,
with gravity. Prints them beside the report's certified values."""

from __future__ import annotations

import json
import sys
from pathlib import Path

import numpy as np
from independent import output_peak_lsim
from test_optim_cell import independent_distance

import fem
from fem.scenes import scene
from jaxflex._loads import CupUtilisation, VonMises
from jaxflex.files import read_trajectory_csv
from optim.cell_file import load_cell

PRESS_CELL = Path(__file__).resolve().parents[1] / "examples" / "press_cell.toml"
N_MODES = 60
SETTLING_S = 4.0


def main(result_dir: str) -> None:
    report = json.loads((Path(result_dir) / "report.json").read_text(encoding="utf-8"))
    move = read_trajectory_csv(Path(result_dir) / "trajectory.csv")
    cell = load_cell(PRESS_CELL)
    result = fem.modal_analysis(*scene("plate"), n_modes=N_MODES, zeta=0.02)
    until_s = move.duration_s + SETTLING_S
    acc = np.asarray(move.acc)
    distance = independent_distance(result, N_MODES, cell, acc, until_s)
    model = result.to_modal_model(points=None)
    gravity, acc_part = cell.rotation.T @ cell.gravity_m_s2, acc @ cell.rotation

    def peak(outputs, functional) -> float:
        return output_peak_lsim(model, outputs, functional, acc_part, move.dt_s, until_s, gravity)

    cups = peak(model.cups.reaction, CupUtilisation(model.cups, 1.5))
    stress = peak(model.stress.stress, VonMises(model.stress.n_points))
    print(f"independent ({N_MODES} modes, {len(result.system.nodes)} nodes, to +{SETTLING_S} s):")
    print(f"  distance {1e3 * distance:.3f} mm, cups {cups:.5f}, von Mises {stress / 1e6:.3f} MPa")
    certified = {c["name"]: c["peak"] for c in report["constraints"]}
    print(f"certified (cycle {report['cycle_time_s']} s): {certified}")


if __name__ == "__main__":
    main(sys.argv[1])
