"""FMI 2.0 and 3.0 co-simulation FMUs of a jaxflex part (see docs/fmu.md).

``export_fmu(model, "part.fmu", move, fmi=Fmi(3))`` writes the FMU (C sources of the exact
modal recursion, gcc-built binaries, versioned binary resource) and, with a move (a
jaxflex.Move), the input CSV and case JSON beside it; its options are objects checked once
(fmu.options: ``Fmi``, ``CellOutputs``, ``Turning``). ``verify("part.fmu")`` validates it
with fmpy, simulates it and compares with ``jaxflex.simulate``. ``export_ssp(model,
"case.ssp", move)`` writes an SSP 1.0 package of the part and a trajectory source FMU
playing the move (fmu.ssp); ``fmu.crosscheck`` runs FMUs and packages in other hosts.
"""

from typing import TYPE_CHECKING

from jaxflex.lazy import lazy_names

if TYPE_CHECKING:  # imported on first use (jaxflex.lazy): the package loads at once
    from fmu.export import ExportResult, export_fmu
    from fmu.options import CellOutputs, Fmi, Turning
    from fmu.ssp import SspResult, export_ssp
    from fmu.toolchain import FmuBuildError
    from fmu.verify import VerifyReport, verify

__getattr__, __dir__ = lazy_names(__name__)

__all__ = [
    "CellOutputs",
    "ExportResult",
    "Fmi",
    "FmuBuildError",
    "SspResult",
    "Turning",
    "VerifyReport",
    "export_fmu",
    "export_ssp",
    "verify",
]
