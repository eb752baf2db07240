"""The option objects of fmu.export_fmu and fmu.export_ssp (fmu.options): each field is
checked when the object is made and refused by its name with what is allowed and what was
given; the objects are frozen; a Turning made from a core Turn carries its path, pivot and
gravity. No FMU is built here (the FMU tests build them with these objects)."""

from __future__ import annotations

import dataclasses
import math
import re

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from fmu.options import CellOutputs, Fmi, Turning
from jaxflex.errors import InputError
from jaxflex.geometry import Cell
from jaxflex.response import Turn, fixed_axis_path

finite = st.floats(-1e6, 1e6, allow_nan=False)


@pytest.mark.parametrize(
    ("kwargs", "message"),
    [
        ({"version": 4}, "version: the FMI version, 2 or 3, got 4"),
        ({"version": True}, "version: the FMI version, 2 or 3, got True"),
        ({"version": "3"}, "version: the FMI version, 2 or 3, got '3'"),
        ({"windows": "auto"}, "windows: None (when mingw-w64 is installed), True or False"),
        ({"windows": 1}, "windows: None (when mingw-w64 is installed), True or False"),
        ({"model_name": ""}, "model_name: None or a non-empty text, got ''"),
        ({"model_name": 7}, "model_name: None or a non-empty text, got 7"),
        ({"description": "  "}, "description: None or a non-empty text, got '  '"),
    ],
)
def test_fmi_refuses_each_field_by_name(kwargs, message):
    with pytest.raises(InputError, match=re.escape(message)):
        Fmi(**kwargs)


@pytest.mark.parametrize(
    ("kwargs", "message"),
    [
        ({"cell": "cell.toml"}, "cell: None or a jaxflex.geometry.Cell"),
        ({"cup_safety": 0.0}, "cup_safety: must be a finite number > 0, got 0.0"),
        ({"cup_safety": math.inf}, "cup_safety: must be a finite number > 0"),
        ({"cup_safety": "high"}, "cup_safety: must be a number > 0, got 'high'"),
        ({"stress": "yes"}, "stress: True or False, got 'yes'"),
    ],
)
def test_cell_outputs_refuse_each_field_by_name(kwargs, message):
    with pytest.raises(InputError, match=re.escape(message)):
        CellOutputs(**kwargs)


@pytest.mark.parametrize(
    ("kwargs", "message"),
    [
        ({"pivot_m": (0.0, 1.0)}, "pivot_m: three finite numbers, m in the model frame"),
        ({"pivot_m": (0.0, np.nan, 0.0)}, "pivot_m: three finite numbers"),
        ({"pivot_m": "origin"}, "pivot_m: three finite numbers"),
        ({"gravity_m_s2": (0, 0)}, "gravity_m_s2: three finite numbers, m/s^2 in the"),
        ({"gravity_m_s2": (0, 0, np.inf)}, "gravity_m_s2: three finite numbers"),
        ({"pose": np.eye(3)}, "pose: None or a jaxflex.response.PosePath"),
    ],
)
def test_turning_refuses_each_field_by_name(kwargs, message):
    with pytest.raises(InputError, match=re.escape(message)):
        Turning(**kwargs)


@settings(max_examples=60, deadline=None)
@given(version=st.integers(-10, 10), windows=st.sampled_from([None, True, False]))
def test_fmi_takes_versions_2_and_3_only(version, windows):
    if version in (2, 3):
        fmi = Fmi(version, windows=windows)
        assert (fmi.version, fmi.windows) == (version, windows)
    else:
        with pytest.raises(InputError, match=rf"version: the FMI version, 2 or 3, got {version}"):
            Fmi(version, windows=windows)


@settings(max_examples=80, deadline=None)
@given(value=st.floats(allow_nan=True, allow_infinity=True))
def test_cup_safety_is_a_finite_positive_number(value):
    if math.isfinite(value) and value > 0:
        assert CellOutputs(cup_safety=value).cup_safety == value
    else:
        with pytest.raises(InputError, match=r"cup_safety: .*got"):
            CellOutputs(cup_safety=value)


@settings(max_examples=80, deadline=None)
@given(
    pivot=st.lists(st.floats(allow_nan=True, allow_infinity=True), min_size=2, max_size=4),
    gravity=st.lists(finite, min_size=3, max_size=3),
)
def test_turning_vectors_are_three_finite_numbers(pivot, gravity):
    if len(pivot) == 3 and all(math.isfinite(x) for x in pivot):
        turning = Turning(pivot, gravity_m_s2=gravity)
        assert turning.pivot_m.tolist() == pivot and turning.gravity_m_s2.tolist() == gravity
        assert not turning.pivot_m.flags.writeable  # frozen all the way down
    else:
        with pytest.raises(InputError, match=r"pivot_m: three finite numbers"):
            Turning(pivot, gravity_m_s2=gravity)


def test_option_objects_are_frozen():
    for option, field in ((Fmi(), "version"), (CellOutputs(), "stress"), (Turning(), "pose")):
        with pytest.raises(dataclasses.FrozenInstanceError):
            setattr(option, field, None)


def test_turning_of_a_core_turn_carries_its_path_pivot_and_gravity():
    path = fixed_axis_path("z", np.r_[0.0, 2.0, -2.0, 0.0], 0.01)
    turn = Turn(path, np.zeros((4, 3)), pivot_m=(0.1, 0.2, 0.3), gravity_m_s2=(0, -9.81, 0))
    turning = Turning.of(turn)
    assert turning.pose is path
    assert turning.pivot_m.tolist() == [0.1, 0.2, 0.3]
    assert turning.gravity_m_s2.tolist() == [0.0, -9.81, 0.0]
    with pytest.raises(InputError, match=r"turn: a jaxflex\.Turn, got PosePath"):
        Turning.of(path)


def test_a_turning_part_in_a_cell_takes_the_cells_gravity():
    cell = Cell(end_m=(0.5, 0.0, 0.0), gravity_m_s2=(0.0, 0.0, -9.0))
    outputs = CellOutputs(cell)
    assert Turning().gravity_in(outputs).tolist() == [0.0, 0.0, -9.0]
    assert Turning(gravity_m_s2=(0, 0, -9.0)).gravity_in(outputs).tolist() == [0.0, 0.0, -9.0]
    assert Turning().gravity_in(CellOutputs()).tolist() == [0.0, 0.0, -9.81]
    with pytest.raises(InputError, match=r"gravity_m_s2: with a cell the cell's"):
        Turning(gravity_m_s2=(0.0, 0.0, -9.81)).gravity_in(outputs)
