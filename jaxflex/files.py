"""Files in and out, for the layers above the core: input files checked before reading
(inputs, validation), outputs written atomically and file sets with a manifest (atomic,
fileset), the trajectory and unit-response CSV files, a model file's fields without the model
class (model_file.read_model_file: no JAX). Readers that run in a child process
use jaxflex.isolated (light: the child does not import JAX). Public: these names are kept
stable; the modules they come from are private.
"""

from __future__ import annotations

from typing import TYPE_CHECKING

from jaxflex.atomic import (
    atomic_open,
    atomic_path,
    make_output_dir,
    remove_stale_temporaries,
    write_text_atomic,
)
from jaxflex.fileset import (
    MANIFEST,
    SetWriter,
    directory_lock,
    read_set,
    writing,
)
from jaxflex.inputs import (
    check_input_file,
    check_text_file,
    read_settings_file,
    read_text,
)
from jaxflex.lazy import lazy_names
from jaxflex.model_file import read_model_file
from jaxflex.scalars import check_positive
from jaxflex.validation import (
    check_output_dir,
    check_output_file,
)

if TYPE_CHECKING:  # they load JAX: imported on first use (jaxflex.lazy), the checks at once
    from jaxflex.convolution import read_unit_response_csv
    from jaxflex.trajectory_io import read_trajectory_csv, read_turn_csv, write_trajectory_csv

__getattr__, __dir__ = lazy_names(__name__)

__all__ = [
    "MANIFEST",
    "SetWriter",
    "atomic_open",
    "atomic_path",
    "check_input_file",
    "check_output_dir",
    "check_output_file",
    "check_positive",
    "check_text_file",
    "directory_lock",
    "make_output_dir",
    "read_model_file",
    "read_set",
    "read_settings_file",
    "read_text",
    "read_trajectory_csv",
    "read_turn_csv",
    "read_unit_response_csv",
    "remove_stale_temporaries",
    "write_text_atomic",
    "write_trajectory_csv",
    "writing",
]
