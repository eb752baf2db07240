"""Cross-checks in co-simulation hosts other than fmpy: an exported FMU replaying its move, or
an SSP package from :func:`fmu.ssp.export_ssp`, run in every available host and compared with
the jaxflex response that describes what the host does.

* An FMU replaying its embedded trajectory (``use_embedded_trajectory = true``) in Ecos or
  libcosim: the move is linear between samples inside the FMU. Reference:
  ``jaxflex.simulate``.
* An SSP package in a host that copies output values to inputs at communication points
  (fmpy's ``simulate_ssp``, Ecos, libcosim; FMI 3.0 in any host): each acceleration sample is
  held over a step. Reference: the exact zero-order-hold response
  (``fmu.verify.reference_response`` with ``hold="zero"``) of the source's values at the
  communication points.
* An SSP package of FMI 2.0 FMUs in fmu.master with the source's output derivatives forwarded
  as the part's input derivatives: the part sees the piecewise-linear move. Reference:
  ``jaxflex.simulate``.
* A turning part's package (the source plays the pose as well): the same two references of
  the turning forcing (fmu.turning_reference): ``jaxflex.simulate_turning`` for fmu.master
  with derivatives forwarded, the exact zero-order hold of the pose samples for the hosts
  that hold values.

The communication step is the trajectory's sample step; a run lasts the FMU's default
experiment. The difference reported is the largest absolute difference of the part's
``deviation`` over all communication points divided by the reference's peak.
"""

from __future__ import annotations

import os
import shutil
import tempfile
import zipfile
from collections.abc import Callable
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np
from fmpy.ssp.ssd import read_ssd
from fmpy.validation import validate_fmu

from fmu import importers
from fmu.master import Session, run_chained
from fmu.ssp import PART, SOURCE, SSD_FILE, held_samples, read_parameters, steps_for, stop_time_of
from fmu.turning_reference import stored_turn, turning_reference
from fmu.verify import read_fmu_resource, reference_response, simulated_model
from jaxflex.errors import InputError
from jaxflex.model import ModalModel
from jaxflex.response import as_move

DEFAULT_RTOL = 1e-9
FMU_HOSTS = ("ecospy", "libcosimpy")
SSP_HOSTS = ("fmpy", "ecospy", "libcosimpy", "jaxflex-master")
_LINEAR = "jaxflex.simulate (linear between samples)"
_HELD = "exact zero-order hold of the samples (jaxflex's engine)"
_TURNING = "jaxflex.simulate_turning (forcing linear between the pose samples)"
_TURNING_HELD = "exact zero-order hold of the pose samples' forcing (jaxflex's engine)"
_FMPY_TURNING = (
    "fmpy's simulate_ssp starts every connection at 0 instead of the source's first output: "
    "a zero quaternion, which the turning part refuses"
)


@dataclass(frozen=True)
class HostRun:
    """One host's run: max |deviation - reference| / peak of the reference over the
    communication points it reported, and which reference that is."""

    host: str
    reference: str
    max_rel_diff: float
    n_points: int
    settle_time_s: float


@dataclass
class CrossReport:
    """Result of :func:`crosscheck_fmu` or :func:`crosscheck_ssp`; ``skipped`` maps hosts
    that were not run to the reason."""

    path: str
    kind: str  # "FMU" or "SSP"
    fmi_version: int
    dt_s: float
    n_steps: int
    validation: list[str] = field(default_factory=list)
    runs: list[HostRun] = field(default_factory=list)
    skipped: dict[str, str] = field(default_factory=dict)
    rtol: float = DEFAULT_RTOL

    @property
    def ok(self) -> bool:
        """Validation clean and every host that ran within ``rtol`` (no host at all is fine:
        the report says why each was skipped)."""
        return not self.validation and all(r.max_rel_diff <= self.rtol for r in self.runs)

    def summary(self) -> str:
        lines = [
            f"{self.path}: {self.kind}, FMI {self.fmi_version}.0, {self.n_steps} steps of "
            f"{self.dt_s:g} s in other hosts"
        ]
        if self.kind == "SSP":
            lines.append(
                "SSP validation: "
                + ("clean" if not self.validation else "; ".join(self.validation))
            )
        for r in self.runs:
            lines.append(
                f"{r.host}: deviation vs {r.reference}: relative {r.max_rel_diff:.3e} "
                f"({r.n_points} points), settle time {r.settle_time_s:.6g} s"
            )
        lines += [f"{host}: not run ({why})" for host, why in self.skipped.items()]
        lines.append("OK" if self.ok else f"FAILED (tolerance {self.rtol:g} relative)")
        return "\n".join(lines)


def _compare(host, reference_name, reference, out, dt_s, prefix="") -> HostRun:
    k = np.rint(np.asarray(out["time"]) / dt_s).astype(int)
    diff = np.abs(np.asarray(out[f"{prefix}deviation"]) - reference[k]).max()
    return HostRun(
        host=host,
        reference=reference_name,
        max_rel_diff=float(diff / np.abs(reference).max()),
        n_points=len(k),
        settle_time_s=float(np.asarray(out[f"{prefix}settle_time"])[-1]),
    )


def _why_not(host: str, fmi_version: int) -> str | None:
    check = {
        "ecospy": importers.ecospy_unavailable,
        "libcosimpy": importers.libcosimpy_unavailable,
    }.get(host)
    why = check() if check else None
    if why is None and fmi_version != 2 and host in ("fmpy", "libcosimpy"):
        why = f"runs FMI 2.0 FMUs only, this is FMI {fmi_version}.0"
    return why


def _check_hosts(hosts, allowed) -> None:
    unknown = set(hosts) - set(allowed)
    if unknown:
        raise InputError(f"hosts: unknown {sorted(unknown)}; choose from {', '.join(allowed)}")


def crosscheck_fmu(
    path: str | os.PathLike, hosts: tuple[str, ...] = FMU_HOSTS, *, rtol: float = DEFAULT_RTOL
) -> CrossReport:
    """Replay the FMU's embedded trajectory in each of ``hosts`` that can run it here, with a
    communication step of its sample step until its default stop time."""
    path = Path(path)
    _check_hosts(hosts, FMU_HOSTS)
    stored = read_fmu_resource(path)
    if stored.acc is None:
        raise InputError(f"{str(path)!r} has no embedded trajectory to replay")
    dt_s = stored.dt_s
    n_steps = steps_for(stop_time_of(path), dt_s)
    report = CrossReport(str(path), "FMU", importers.fmi_version_of(path), dt_s, n_steps, rtol=rtol)
    reference, _ = reference_response(simulated_model(stored, path), stored.move, n_steps)
    replay = {"use_embedded_trajectory": True}
    runners = {"ecospy": importers.ecos_fmu, "libcosimpy": importers.libcosim_fmu}
    for host in hosts:
        why = _why_not(host, report.fmi_version)
        if why is not None:
            report.skipped[host] = why
            continue
        out = runners[host](path, n_steps, dt_s, replay)
        report.runs.append(_compare(host, _LINEAR, reference, out, dt_s))
    return report


def _ssp_validation(path: Path, folder: Path) -> list[str]:

    problems = []
    try:
        read_ssd(str(path), validate=True)  # against the SSP 1.0 XML schema
    except Exception as exc:  # fmpy raises a bare Exception with the schema messages
        problems.append(f"{SSD_FILE}: {exc}")
    for name in (PART, SOURCE):
        problems += [f"{name}.fmu: {p}" for p in validate_fmu(str(folder / f"{name}.fmu"))]
    return problems


def _master(folder: Path, fmi_version: int, parameters, dt_s: float, n_steps: int):
    """The package in fmu.master: every output of the source connected to the part's input
    of that name, the part initialized with them (a turning part rests in the first pose)."""
    with (
        Session(folder / f"{SOURCE}.fmu", instance_name=SOURCE) as source,
        Session(folder / f"{PART}.fmu", instance_name=PART) as part,
    ):
        names = tuple(v.name for v in source.description.modelVariables if v.causality == "output")
        source.start(0.0)
        part.start(0.0, {**{name: source.get(name) for name in names}, **parameters})
        out = run_chained(source, part, dt_s, n_steps, forward_rates=fmi_version == 2, names=names)
    return {"time": out["time"], **{f"part.{k}": v for k, v in out.items() if k != "time"}}


def _references(path, stored, model, part_model, n_steps: int) -> dict[str, Callable]:
    """The references of a package's run, by the hold of the inputs ("linear": derivatives
    forwarded; "zero": values held): callables giving (name, deviation at the communication
    points). ``model`` is the stored model as simulated, ``part_model`` the turning part's."""
    dt_s = stored.dt_s
    if stored.turning is None:
        move = stored.move
        held = as_move(held_samples(move, dt_s, n_steps), dt_s)
        return {
            "linear": lambda: (_LINEAR, reference_response(model, move, n_steps)[0]),
            "zero": lambda: (_HELD, reference_response(model, held, n_steps, hold="zero")[0]),
        }
    if part_model is None:
        raise InputError(
            f"{path}: the package of a turning part; its check needs the part's model "
            "(part_model=...)"
        )
    damped = part_model.with_damping(model.zeta)
    turn = stored_turn(stored, damped, n_steps)
    return {
        "linear": lambda: (_TURNING, turning_reference(damped, turn)),
        "zero": lambda: (_TURNING_HELD, turning_reference(damped, turn, hold="zero")),
    }


def crosscheck_ssp(
    path: str | os.PathLike,
    hosts: tuple[str, ...] = SSP_HOSTS,
    *,
    rtol: float = DEFAULT_RTOL,
    part_model: ModalModel | None = None,
) -> CrossReport:
    """Validate the SSP package at ``path`` (SSD against the SSP 1.0 schema, both FMUs with
    fmpy) and run it in each of ``hosts`` that can run it here. A turning part's package
    needs the model it was exported from (with its rotation data, which the part FMU
    does not hold whole) as ``part_model``."""
    path = Path(path)
    if not path.is_file():
        raise InputError(f"SSP package {str(path)!r} does not exist")
    _check_hosts(hosts, SSP_HOSTS)
    tmp = Path(tempfile.mkdtemp(prefix="jaxflex_ssp_check_"))
    try:
        with zipfile.ZipFile(path) as zf:
            zf.extractall(tmp)
        folder = tmp / "resources"
        part_fmu = folder / f"{PART}.fmu"
        stored = read_fmu_resource(part_fmu)
        if stored.acc is None:
            raise InputError(f"{path}: resources/{PART}.fmu carries no trajectory")
        dt_s = stored.dt_s
        n_steps = steps_for(stop_time_of(part_fmu), dt_s)
        fmi_version = importers.fmi_version_of(part_fmu)
        report = CrossReport(str(path), "SSP", fmi_version, dt_s, n_steps, rtol=rtol)
        report.validation = _ssp_validation(path, folder)
        parameters = read_parameters(path).get(PART, {})
        model = simulated_model(stored, part_fmu, parameters)
        references = _references(path, stored, model, part_model, n_steps)
        runners: dict[str, Callable[[], dict]] = {
            "fmpy": lambda: importers.fmpy_ssp(path, n_steps, dt_s),
            "ecospy": lambda: importers.ecos_ssp(path, n_steps, dt_s),
            "libcosimpy": lambda: importers.libcosim_ssp(path, n_steps, dt_s),
            "jaxflex-master": lambda: _master(folder, fmi_version, parameters, dt_s, n_steps),
        }
        for host in hosts:
            why = _why_not(host, fmi_version)
            if why is None and host == "fmpy" and stored.turning is not None:
                why = _FMPY_TURNING
            if why is not None:
                report.skipped[host] = why
                continue
            out = runners[host]()
            linear = host == "jaxflex-master" and fmi_version == 2  # derivatives forwarded
            name, reference = references["linear" if linear else "zero"]()
            report.runs.append(_compare(host, name, reference, out, dt_s, "part."))
        return report
    finally:
        shutil.rmtree(tmp, ignore_errors=True)
