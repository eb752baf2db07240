"""FMU speed at C level: one communication step and one instantiation.

A small C harness (fmu/c/harness.c) dlopen()s the exported FMU's library like an importer,
times many instantiations and a long run of communication steps (inputs and input
derivatives set and the deviation read every step; timed in chunks of 100 steps, so the
median is robust against other processes on the machine), and prints the figures as JSON.

    .venv/bin/python -m fmu.bench            # K = 1099 points, M = 40 modes, FMI 2.0 and 3.0
    .venv/bin/python -m fmu.bench --points 66308 --fmi 3 --array   # every node, read each step

Targets (issue 5): one step <= 30 us (the preprint's FMU: 0.85 ms per 10 ms step),
instantiation with a ~1 MB resource <= 10 ms.
"""

from __future__ import annotations

import argparse
import json
import subprocess
import sys
import tempfile
import zipfile
from collections.abc import Callable
from pathlib import Path
from typing import Any

import numpy as np

from fmu.build import C_DIR, FmuBuildError, fmi_headers, host_target
from fmu.export import export_fmu
from jaxflex.model import ModalModel

STEP_TARGET_US = 30.0
INSTANTIATE_TARGET_US = 10_000.0
PREPRINT_STEP_US = 850.0


def compile_harness(fmi_version: int, out_file: Path, array_points: int | None = None) -> Path:
    """Build fmu/c/harness.c for FMI ``fmi_version`` into ``out_file``; with ``array_points``
    (FMI 3.0) it also reads the displaced-points array output (K x 3) after every step."""
    array = [f"-DHARNESS_ARRAY_POINTS={array_points}"] if array_points else []
    cmd = [
        host_target().compiler,
        "-std=c99",
        "-O2",
        "-Wall",
        "-Wextra",
        f"-DHARNESS_FMI={fmi_version}",
        *array,
        f"-I{fmi_headers()}",
        str(C_DIR / "harness.c"),
        "-o",
        str(out_file),
        "-ldl",
        "-lm",
    ]
    proc = subprocess.run(cmd, capture_output=True, text=True)
    if proc.returncode != 0:
        raise FmuBuildError(f"compiling the harness failed:\n{proc.stderr.strip()}")
    return out_file


def unpack(fmu_path: Path, folder: Path) -> tuple[Path, Path, str]:
    """Extract the FMU: (shared library, resources folder, instantiation token)."""
    from fmpy import read_model_description

    with zipfile.ZipFile(fmu_path) as zf:
        zf.extractall(folder)
    md = read_model_description(str(folder))
    plat = host_target().folder(int(md.fmiVersion[0]))
    ident = md.coSimulation.modelIdentifier
    return folder / "binaries" / plat / f"{ident}.so", folder / "resources", md.guid


def resource_location(fmi_version: int, resources: Path) -> str:
    """What an importer passes: a file URI (FMI 2.0) or a path ending in '/' (FMI 3.0)."""
    return resources.resolve().as_uri() + "/" if fmi_version == 2 else f"{resources.resolve()}/"


def bench_model(n_points: int, n_modes: int, seed: int = 0) -> ModalModel:
    """A model of the benchmark size: frequencies 2-400 Hz, random shapes and participation."""
    rng = np.random.default_rng(seed)
    return ModalModel(
        freq_hz=np.geomspace(2.0, 400.0, n_modes),
        zeta=np.full(n_modes, 0.02),
        gamma=rng.normal(size=(n_modes, 3)),
        shapes=rng.normal(size=(n_points, 3, n_modes)) * 0.05,
        points=rng.uniform(size=(n_points, 3)),
        meta={"source": "fmu.bench"},
    )


def run(
    n_points: int = 1099,
    n_modes: int = 40,
    n_steps: int = 20_000,
    dt_s: float = 0.01,
    repeats: int = 50,
    fmi_versions: tuple[int, ...] = (2, 3),
    progress: Callable[[str], None] | None = None,
    read_array: bool = False,
) -> dict[str, Any]:
    """Export a K x M model, time it with the C harness; figures per FMI version."""
    say = progress or (lambda msg: None)
    model = bench_model(n_points, n_modes)
    report: dict[str, Any] = {
        "command": f"{Path(sys.executable).name} -m fmu.bench",
        "n_points": n_points,
        "n_modes": n_modes,
        "dt_s": dt_s,
        "reads_displaced_points_array": read_array,
        "targets": {
            "step_us": STEP_TARGET_US,
            "instantiate_us": INSTANTIATE_TARGET_US,
            "preprint_step_us": PREPRINT_STEP_US,
        },
    }
    with tempfile.TemporaryDirectory(prefix="jaxflex_fmu_bench_") as tmp:
        tmp = Path(tmp)
        for version in fmi_versions:
            say(f"FMI {version}.0: export K={n_points}, M={n_modes}")
            result = export_fmu(model, tmp / f"bench{version}.fmu", fmi_version=version)
            library, resources, token = unpack(result.fmu_path, tmp / f"fmu{version}")
            array = n_points if read_array and version == 3 else None
            harness = compile_harness(version, tmp / f"harness{version}", array)
            say(f"FMI {version}.0: {repeats} instantiations, {n_steps} steps")
            cmd = [
                str(harness),
                str(library),
                resource_location(version, resources),
                token,
                "bench",
                str(n_steps),
                repr(dt_s),
                str(repeats),
            ]
            proc = subprocess.run(cmd, capture_output=True, text=True, check=True)
            figures = json.loads(proc.stdout)
            figures["resource_bytes"] = result.resource_bytes
            figures["speedup_vs_preprint"] = PREPRINT_STEP_US / figures["step_us_median"]
            figures["meets_targets"] = (
                figures["step_us_median"] <= STEP_TARGET_US
                and figures["instantiate_us_median"] <= INSTANTIATE_TARGET_US
            )
            report[f"fmi{version}"] = figures
    return report


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(prog="python -m fmu.bench", description=__doc__.split("\n")[0])
    parser.add_argument(
        "--points", type=int, default=1099, help="monitored points K (default 1099)"
    )
    parser.add_argument("--modes", type=int, default=40, help="modes M (default 40)")
    parser.add_argument(
        "--steps", type=int, default=20_000, help="timed communication steps (default 20000)"
    )
    parser.add_argument(
        "--fmi", type=int, nargs="+", choices=(2, 3), default=[2, 3], help="FMI versions (2 3)"
    )
    parser.add_argument(
        "--array",
        action="store_true",
        help="FMI 3.0: also read the displaced points of every node (K x 3 array) each step",
    )
    args = parser.parse_args(argv)
    for name in ("points", "modes", "steps"):
        if getattr(args, name) < 1:
            parser.error(f"--{name}: must be at least 1, got {getattr(args, name)}")
    report = run(
        n_points=args.points,
        n_modes=args.modes,
        n_steps=args.steps,
        fmi_versions=tuple(args.fmi),
        read_array=args.array,
        progress=lambda msg: print(msg, file=sys.stderr, flush=True),
    )
    print(json.dumps(report, indent=2))
    return 0


if __name__ == "__main__":
    sys.exit(main())
