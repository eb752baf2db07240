"""FMI 2.0 and 3.0 co-simulation FMUs of a jaxflex part (see docs/fmu.md).

``export_fmu(model, "part.fmu", fmi_version=2|3, trajectory=(acc, dt_s))`` writes the FMU
(C sources of the exact modal recursion, gcc-built binaries, versioned binary resource) and,
with a trajectory, the input CSV and case JSON beside it. ``verify("part.fmu")`` validates it
with fmpy, simulates it and compares with ``jaxflex.simulate``. ``export_ssp(model,
"case.ssp", 2, (acc, dt_s))`` writes an SSP 1.0 package of the part and a trajectory source
FMU playing the move (fmu.ssp); ``fmu.crosscheck`` runs FMUs and packages in other hosts.
"""

from typing import TYPE_CHECKING

from jaxflex.lazy import lazy_names

if TYPE_CHECKING:  # imported on first use (jaxflex.lazy): the package loads at once
    from fmu.export import ExportResult, export_fmu
    from fmu.ssp import SspResult, export_ssp
    from fmu.toolchain import FmuBuildError
    from fmu.verify import VerifyReport, verify

__getattr__, __dir__ = lazy_names(__name__)

__all__ = [
    "ExportResult",
    "FmuBuildError",
    "SspResult",
    "VerifyReport",
    "export_fmu",
    "export_ssp",
    "verify",
]
