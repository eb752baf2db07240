"""Files in and out, for the layers above the core: input files checked before reading
(inputs, validation), outputs written atomically and file sets with a manifest (atomic,
fileset), the trajectory and unit-response CSV files, a model file's fields without the model
class (model_file.read_model_file: no JAX).

Every output of every command is written the one way: its path checked before any work
(``check_output_file`` / ``check_output_dir``: never a symbolic link, device, FIFO or
directory in the way; this also declares it an output of the command), then written with
``atomic_open`` / ``atomic_path`` / ``write_text_atomic`` (a new file renamed over the
target) or as a set (``writing``). What a command writes is whole or absent: the
dispatcher runs every command in ``whole_or_absent``, which undoes its declared outputs if
it fails; ``kept_writes`` for stores a rerun resumes from. Readers that run in a child process
use jaxflex.isolated (light: the child does not import JAX). Public: these names are kept
stable; the modules they come from are private.
"""

from __future__ import annotations

from typing import TYPE_CHECKING

from jaxflex._atomic import (
    atomic_open,
    atomic_path,
    check_target,
    make_output_dir,
    remove_output,
    remove_stale_temporaries,
    write_text_atomic,
)
from jaxflex._fileset import (
    MANIFEST,
    SetWriter,
    check_set_dir,
    directory_lock,
    file_digest,
    read_set,
    writing,
)
from jaxflex._inputs import (
    check_input_file,
    check_text_file,
    named,
    read_settings_file,
    read_text,
)
from jaxflex._model_file import read_model_file
from jaxflex._scalars import check_positive
from jaxflex._undo import kept_writes, whole_or_absent
from jaxflex._validation import (
    check_output_dir,
    check_output_file,
)
from jaxflex.lazy import lazy_names

if TYPE_CHECKING:  # they load JAX: imported on first use (jaxflex.lazy), the checks at once
    from jaxflex._convolution import read_unit_response_csv
    from jaxflex._trajectory_io import read_trajectory_csv, read_turn_csv, write_trajectory_csv

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
    "check_set_dir",
    "check_target",
    "check_text_file",
    "directory_lock",
    "file_digest",
    "kept_writes",
    "make_output_dir",
    "named",
    "read_model_file",
    "read_set",
    "read_settings_file",
    "read_text",
    "read_trajectory_csv",
    "read_turn_csv",
    "read_unit_response_csv",
    "remove_output",
    "remove_stale_temporaries",
    "whole_or_absent",
    "write_text_atomic",
    "write_trajectory_csv",
    "writing",
]
