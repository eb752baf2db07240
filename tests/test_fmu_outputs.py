"""A new FMU output is one row in fmu.variables.VARIABLES and one C function in
fmu/c/jxf_values.c: here both are added by the test (a copy of the C sources with the
function appended, the table with the row appended) and the FMU built from them reports the
new output, for FMI 2.0 and 3.0, without any other change to fmu.

The output: deviation_z = max over the points of |u_z|, m.
"""

from __future__ import annotations

import shutil

import numpy as np
import pytest
from conftest import random_model
from fmpy.validation import validate_fmu
from test_fmu_export import smooth_profile

import fmu.export
import fmu.variables
import jaxflex
from fmu import export_fmu
from fmu.master import Session
from fmu.options import Fmi
from fmu.toolchain import C_DIR
from fmu.variables import Variable

DT = 0.01
N_STEPS = 80  # 60 steps of move, then free vibration
DEVIATION_Z = Variable(
    "deviation_z", 13, "real", "output", "continuous", "calculated", "m",
    "Largest |u_z| over the monitored points at the communication point, m",
    "DEVIATION_Z",
)  # fmt: skip
C_FUNCTION = """
void jxf_value_deviation_z(const jxf_model *m, double *out) {
    double best = 0.0, u[3];
    int p;
    for (p = 0; p < m->n_points; ++p) {
        jxf_point_displacement(m, p, u); /* evaluated now where the step left it out */
        best = fabs(u[2]) > best ? fabs(u[2]) : best;
    }
    *out = best;
}
"""


@pytest.fixture(scope="module")
def part():
    return random_model(5, n_points=25, n_modes=5, f_min_hz=2.0, f_max_hz=60.0, zeta=0.03)


@pytest.fixture
def with_deviation_z(tmp_path, monkeypatch):
    """The two additions, made outside the package: sources copied, table extended."""
    sources = tmp_path / "c"
    shutil.copytree(C_DIR, sources)
    with (sources / "jxf_values.c").open("a") as handle:
        handle.write(C_FUNCTION)
    monkeypatch.setattr(fmu.export, "_C_DIR", sources)
    monkeypatch.setattr(fmu.variables, "VARIABLES", (*fmu.variables.VARIABLES, DEVIATION_Z))


def _run(path, acc, rates):
    """deviation_z and deviation after each of N_STEPS steps of DT from rest."""
    out = []
    with Session(path) as session:
        session.start(0.0)
        for k in range(N_STEPS):
            session.set_inputs(acc[k], None if rates is None else rates[k])
            session.step(k * DT, DT)
            out.append((session.get("deviation_z"), session.get("deviation")))
        points = session.get("undeformed_points") if session.fmi_version == 3 else None
        displaced = session.get("displaced_points") if session.fmi_version == 3 else None
    return np.array(out), points, displaced


def test_a_new_output_is_one_table_row_and_one_c_function(part, tmp_path, with_deviation_z):
    acc = np.zeros((N_STEPS + 1, 3))
    acc[:61] = smooth_profile(3, 60)
    rates = np.diff(acc, axis=0) / DT
    for version in (2, 3):
        result = export_fmu(part, tmp_path / f"z{version}.fmu", fmi=Fmi(version, windows=False))
        assert result.compiler_messages == ""
        assert validate_fmu(str(result.fmu_path)) == []
        values, points, displaced = _run(result.fmu_path, acc, rates if version == 2 else None)
        z, deviation = values.T
        assert np.all(z <= deviation) and z.max() > 0.5 * deviation.max()
        if version == 2:
            # linear inputs: the FMU's step is jaxflex's first-order hold, the same closed
            # forms in float64; rounding differences ~1e-15 of the peak (see test_fmu_accuracy)
            ref = jaxflex.simulate(part, acc, DT, displacement=True).displacement
            expected = np.abs(np.asarray(ref)[1:, :, 2]).max(axis=1)
            np.testing.assert_allclose(z, expected, rtol=0, atol=1e-12 * expected.max())
        else:
            # the last step's value against the FMU's own K x 3 arrays: (points + u) - points
            # recovers u_z up to one rounding of the coordinates (|points| <= 1 m here)
            u_z = np.abs(displaced[:, 2] - points[:, 2]).max()
            eps = np.finfo(float).eps * max(1.0, np.abs(points).max())
            assert z[-1] == pytest.approx(u_z, abs=2 * eps)
