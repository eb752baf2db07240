"""fem: parts, grippers and modal models with scikit-fem (offline step of jaxflex).

Part + gripper -> finite-element model -> modal analysis -> jaxflex.ModalModel; plus the
full-order transient reference, meshio export and pictures. Geometry in metres, SI units.
"""

from typing import TYPE_CHECKING

from jaxflex.lazy import lazy_names

if TYPE_CHECKING:  # imported on first use (jaxflex.lazy): the package loads at once
    from fem.damping import Rayleigh
    from fem.export import export_modes, export_transient, plot_part
    from fem.imports.ansys import from_ansys
    from fem.imports.imported import ImportedModes
    from fem.imports.nastran.door import from_nastran
    from fem.imports.r1 import R1Identification, from_r1
    from fem.materials import PRESETS, Material
    from fem.modal import ModalResult, describe_model, modal_analysis
    from fem.parts import Part, curved_panel, read_cad, read_mesh, rectangular_plate
    from fem.scenes import default_gripper, default_model, scene
    from fem.sizing.request import Accuracy
    from fem.sizing.run import SizingResult, size_model
    from fem.supports import ClampedEdge, PointSupport, SimplySupportedEdge, SuctionCup, Support
    from fem.transient import TransientResult, agreement, transient_reference

__getattr__, __dir__ = lazy_names(__name__)

__all__ = [
    "PRESETS",
    "Accuracy",
    "ClampedEdge",
    "ImportedModes",
    "Material",
    "ModalResult",
    "Part",
    "PointSupport",
    "R1Identification",
    "Rayleigh",
    "SimplySupportedEdge",
    "SizingResult",
    "SuctionCup",
    "Support",
    "TransientResult",
    "agreement",
    "curved_panel",
    "default_gripper",
    "default_model",
    "describe_model",
    "export_modes",
    "export_transient",
    "from_ansys",
    "from_nastran",
    "from_r1",
    "modal_analysis",
    "plot_part",
    "read_cad",
    "read_mesh",
    "rectangular_plate",
    "scene",
    "size_model",
    "transient_reference",
]
