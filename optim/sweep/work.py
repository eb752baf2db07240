"""The two steps of a case, as plain functions that any executor can run (in-process or on a
dask worker): the finite-element modal analysis of a layout, and the optimisation of a move
for that model. Neither raises for a failing case: errors come back as records
(``status = "error"``, the stage, the exception type and message) so a sweep goes on.

Models travel as dicts of numpy arrays (:func:`model_payload`). Models of one size share the
compiled code whatever their meta (FE timings, gripper): meta is not part of the pytree
structure of jaxflex.ModalModel.
"""

from __future__ import annotations

import json
import os
import socket
import time
import traceback
import warnings

import numpy as np

import fem
from jaxflex.errors import JaxflexError, JaxflexWarning
from jaxflex.model import ModalModel
from jaxflex.runtime import enable_compile_cache
from optim.limits import Limits
from optim.optimize import optimize
from optim.options import Budget, RobustSpec, Search
from optim.sweep.part import build_part, monitor_points

_ARRAYS = ("freq_hz", "zeta", "gamma", "shapes", "points")


def model_payload(model: ModalModel) -> dict:
    """A ModalModel as a picklable dict of numpy arrays plus its meta as JSON text."""
    data = {name: np.asarray(getattr(model, name)) for name in _ARRAYS}
    data["meta_json"] = json.dumps(dict(model.meta), sort_keys=True)
    return data


def payload_model(payload: dict) -> ModalModel:
    """The ModalModel of :func:`model_payload`."""
    return ModalModel(*(payload[name] for name in _ARRAYS), meta=json.loads(payload["meta_json"]))


def _error(stage: str, exc: BaseException) -> dict:
    expected = isinstance(exc, JaxflexError)
    return {
        "status": "error",
        "stage": stage,
        "error_type": type(exc).__name__,
        "error": str(exc),
        "traceback": None if expected else "".join(traceback.format_exception(exc)[-6:]),
    }


def _where() -> str:
    return f"{socket.gethostname()}:{os.getpid()}"


def analyse_layout(job: dict) -> dict:
    """Finite-element step for one layout (``cases.layout_job``): the modal model at the
    monitored points and a summary, or an error record (stage "fe")."""
    start, cpu = time.perf_counter(), time.process_time()
    try:
        settings = job["model"]
        part = build_part(job["part"])
        cups = [fem.SuctionCup(c[0], c[1], c[-1], z=c[2] if len(c) == 4 else None)
                for c in job["cups"]]  # fmt: skip
        result = fem.modal_analysis(
            part, cups, n_modes=settings["n_modes"], zeta=settings["zeta"], progress=False
        )
        model = result.to_modal_model(
            points=monitor_points(part, settings["monitor_grid"]), outputs=False
        )
    except Exception as exc:  # recorded, the sweep goes on
        return {
            **_error("fe", exc),
            "fe_wall_s": time.perf_counter() - start,
            "fe_cpu_s": time.process_time() - cpu,
            "worker": _where(),
        }
    stats = result.system.stats
    return {
        "status": "ok",
        "model": model_payload(model),
        "fe": {
            "n_dof": int(stats["n_dof"]),
            "n_modes": model.n_modes,
            "n_points": model.n_points,
            "first_freq_hz": float(model.freq_hz[0]),
            "mass_kg": float(result.mass_kg),
            "mass_fraction_z": _finite_or_none(result.cumulative_fraction[2]),
            "fe_wall_s": time.perf_counter() - start,
            "fe_cpu_s": time.process_time() - cpu,
        },
        "worker": _where(),
    }


def _finite_or_none(value) -> float | None:
    value = float(value)
    return value if np.isfinite(value) else None


def fe_from_model(model: ModalModel, fe_summary: dict) -> dict:
    """An ``analyse_layout`` outcome for a model already on disk (a restarted sweep)."""
    return {"status": "ok", "model": model_payload(model), "fe": fe_summary, "worker": None}


def optimise_case(fe: dict, job: dict) -> dict:
    """Optimisation step of one case (``cases.case_job``) on the outcome of
    :func:`analyse_layout`: the case's record (see optim.sweep.table for the fields)."""
    base = {"case_id": job["case_id"], "finished_unix_s": None}
    if fe["status"] != "ok":
        return {**base, **{k: v for k, v in fe.items() if k != "model"}, "fe": None}
    enable_compile_cache()  # a worker process loads what the others compiled (once a process)
    start, cpu = time.perf_counter(), time.process_time()
    settings, move = job["optimization"], job["move"]
    try:
        robust = settings["robust"]
        with warnings.catch_warnings():  # kept in the record; the sweep's summary counts them
            warnings.simplefilter("ignore", JaxflexWarning)
            result = optimize(
                payload_model(fe["model"]),
                move["distance_m"],
                Limits(move["vmax"], move["amax"], move["jmax"]),
                settings["dt_s"],
                settings["threshold_m"],
                robust=None if robust is None else RobustSpec.from_dict(robust),
                search=Search(method=settings["method"], progress=False),
                budget=Budget(max_duration_s=settings["max_duration_s"]),
            )
    except Exception as exc:  # recorded, the sweep goes on
        return {
            **base,
            **_error("optimization", exc),
            "fe": fe["fe"],
            "opt_wall_s": time.perf_counter() - start,
            "opt_cpu_s": time.process_time() - cpu,
            "worker": _where(),
            "finished_unix_s": time.time(),
        }
    best = result.baselines.best()
    comparison = result.comparison()
    return {
        **base,
        "status": "ok",
        "fe": fe["fe"],
        "opt": {
            "cycle_time_s": result.cycle_time_s,
            "transfer_time_s": result.transfer_time_s,
            "settle_time_s": result.settle_time_s,
            "n_steps": result.n_steps,
            "worst_cycle_time_s": result.worst_cycle_time_s,
            "kinematic_floor_s": result.baselines.kinematic_floor_s,
            "best_baseline": best.name,
            "best_baseline_cycle_time_s": best.cycle_time_s,
            "best_baseline_s": comparison["best_baseline_s"],  # by the optimised objective
            "source": result.source,
            "warnings": result.warnings,
            "peak_deviation_m": result.peak_deviation_m,
            "deviation_at_stop_m": result.deviation["at_stop_m"],
            "opt_wall_s": time.perf_counter() - start,
            "opt_cpu_s": time.process_time() - cpu,
        },
        "acc_m_s2": np.asarray(result.acc).tolist(),
        "worker": _where(),
        "finished_unix_s": time.time(),
    }
