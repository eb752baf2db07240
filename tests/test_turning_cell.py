"""The cell with a turning part: cup reactions against Newton-Euler in closed form, the static
response to the rotational loads against an independent sparse solve of the FE system, the
quasi-static share of the modes left out on the curved shell panel, and the clearance of the
turning part against a brute-force evaluation of every node's world position."""

from __future__ import annotations

import warnings

import numpy as np
import pytest
import scipy.sparse.linalg as sla
from sheet_parts import sheet_moments

import fem
import jaxflex
from fem.elements.solid import SolidOutputs
from jaxflex import as_move
from jaxflex._cell import Box, HalfSpace
from jaxflex._outputs import voigt_rotation
from jaxflex._pose import axis_rotation, fixed_axis_path, turn_acceleration
from jaxflex._profile import jerk_limited_move, kinematics_at
from jaxflex._rotation_residual import rotation_residual
from jaxflex._turning import Turn, simulate_turning
from jaxflex._turning_collision import turning_min_distance
from jaxflex._turning_outputs import TurningInputs, output_values, turning_inputs, turning_loads
from jaxflex.errors import JaxflexWarning

DT = 1e-3
G_WORLD = np.array([0.0, 0.0, -9.81])
RATE, ACC, JERK = 3.0, 20.0, 400.0  # rad/s, rad/s^2, rad/s^3: the robot rates
WIDTH, HEIGHT = 0.4, 0.3
CUPS = [(x, y) for x in (0.1, 0.3) for y in (0.08, 0.22)]


def _skew(v):
    return np.array([[0.0, -v[2], v[1]], [v[2], 0.0, -v[0]], [-v[1], v[0], 0.0]])


def _sheet(element, material="steel", thickness=2e-3, n_modes=6, mesh=0.1):
    part = fem.rectangular_plate(WIDTH, HEIGHT, thickness, material, mesh, element=element)
    cups = [fem.SuctionCup(x, y, 0.03) for x, y in CUPS]
    return fem.modal_analysis(part, cups, n_modes=n_modes, zeta=0.02, progress=False)


def _move(axis, angle_deg, distance_m, start=None):
    """A turn about ``axis`` by ``angle_deg`` at the issue's rates with a jerk-limited
    translation of the pivot by ``distance_m`` (2 / 10 / 100 limits), both from rest, padded
    to the same length."""
    alpha = turn_acceleration(np.radians(angle_deg), RATE, ACC, JERK, DT)
    distance = np.asarray(distance_m, float)
    acc = np.zeros((2, 3))
    if distance.any():
        acc = jerk_limited_move(distance, 2.0, 10.0, 100.0, DT).acc
    n = max(len(alpha), len(acc))
    alpha = np.pad(alpha, (0, n - len(alpha)))
    acc = np.pad(acc, ((0, n - len(acc)), (0, 0)))
    return fixed_axis_path(axis, alpha, DT, start=start), acc


def stiff_sheet(stiffer: float = 1e6):
    """(modal result, model): a 0.4 x 0.3 m, 2 mm thin solid of a steel ``stiffer`` times
    stiffer (1e6: first mode in the hundreds of kHz), on four cups."""
    material = fem.Material("stiff steel", 2.1e11 * stiffer, 0.3, 7850.0)
    result = _sheet("hex2", material)
    return result, result.to_modal_model(points=8)


@pytest.fixture(scope="module")
def stiff():
    return stiff_sheet()


def test_cups_carry_newton_euler_during_a_turning_move(stiff):
    """A stiff part turned 90 degrees about a skew axis from a tilted start while its pivot
    moves 0.5 m, under gravity: the cups' forces add up to m (a_c - g) and their moments
    about the gripper origin to J alpha + w x J w + m c x (a_O - g) at every sample, to 1e-6
    of the peak (the modes' dynamic remainder of a part this stiff is (w_move / omega_1)^2 ~
    1e-9; mass, centre and inertia in closed form from the sheet's dimensions)."""
    result, model = stiff
    path, acc, pivot = skew_turn()
    loads = turning_loads(model, Turn(path, acc, pivot_m=pivot), extend_s=0.02)
    force, moment = newton_euler(result, path, acc, pivot, len(loads.t_s))
    reactions = loads.reactions
    cup_centres = np.asarray(model.cups.centre_m)
    got_force = reactions[..., :3].sum(axis=1)
    got_moment = (reactions[..., 3:] + np.cross(cup_centres[None], reactions[..., :3])).sum(1)
    assert np.abs(got_force - force).max() <= 1e-6 * np.abs(force).max()
    assert np.abs(got_moment - moment).max() <= 1e-6 * np.abs(moment).max()
    assert loads.static_complete
    assert loads.utilisation.shape == (len(loads.t_s), 4) and (loads.utilisation > 0).all()


def skew_turn():
    """(path, acc, pivot): the stiff part's move: 90 degrees about a skew axis from a start
    tilted 20 degrees about x, while the pivot (0.1, 0.05, 0.02) m moves by (0.5, 0.2, 0.3)
    m."""
    start = axis_rotation(np.array([1.0, 0.0, 0.0]), np.array([np.radians(20.0)]))[0]
    path, acc = _move((0.3, -0.2, 1.0), 90.0, (0.5, 0.2, 0.3), start=start)
    return path, acc, np.array([0.1, 0.05, 0.02])


def newton_euler(result, path, acc, pivot, n_all):
    """(force (T, 3) N, moment about the gripper origin (T, 3) N m) the cups of the stiff
    2 mm sheet of ``result`` carry at the T = ``n_all`` samples of the move (and rest after
    it), body components: m (a_c - g) and J alpha + w x J w + m c x (a_O - g), with mass,
    centre and inertia in closed form from the sheet's dimensions."""
    t = 2e-3
    z0 = float(np.mean(result.system.nodes[:, 2]))
    mass = 7850.0 * WIDTH * HEIGHT * t
    centre = np.array([WIDTH / 2, HEIGHT / 2, z0])
    second = mass * np.array(  # int rho r r^T over the box [0, W] x [0, H] x [z0 -+ t/2]
        [
            [WIDTH**2 / 3, WIDTH * HEIGHT / 4, WIDTH * z0 / 2],
            [WIDTH * HEIGHT / 4, HEIGHT**2 / 3, HEIGHT * z0 / 2],
            [WIDTH * z0 / 2, HEIGHT * z0 / 2, z0**2 + t**2 / 12],
        ]
    )
    inertia = np.trace(second) * np.eye(3) - second
    w = np.pad(path.omega_rad_s, ((0, n_all - len(acc)), (0, 0)))
    alpha = np.pad(path.alpha_rad_s2, ((0, n_all - len(acc)), (0, 0)))
    rot = np.concatenate([path.rotation, np.repeat(path.rotation[-1:], n_all - len(acc), 0)])
    a_world = np.pad(acc, ((0, n_all - len(acc)), (0, 0)))
    arm = -pivot
    a_origin = (
        np.einsum("kji,kj->ki", rot, a_world) + np.cross(alpha, arm) + np.cross(w, np.cross(w, arm))
    )
    g_body = np.einsum("kji,j->ki", rot, G_WORLD)
    a_centre = a_origin + np.cross(alpha, centre) + np.cross(w, np.cross(w, centre))
    force = mass * (a_centre - g_body)
    moment = (
        alpha @ inertia.T + np.cross(w, w @ inertia.T) + mass * np.cross(centre, a_origin - g_body)
    )
    return force, moment


def _rest_inputs(model, g_body, b):
    """The inputs of jaxflex._turning_outputs at rest under the base acceleration -g_body and
    the constant rotational load coefficients b: the modes at their static coordinates."""
    omega = np.asarray(model.omega_rad_s)
    s = np.asarray(model.rotation.shape_integrals).reshape(-1, 9)
    q = (np.asarray(model.gamma) @ g_body - s @ b) / omega**2
    return TurningInputs(np.zeros(1), q[None], 0 * q[None], -g_body[None], b[None])


@pytest.mark.parametrize(
    ("element", "case"), [("hex2", "spin"), ("hex2", "tilt"), ("morley", "spin+tilt")]
)
def test_static_response_against_a_sparse_solve(element, case):
    """At rest under a constant spin (the centrifugal load) and/or a static tilt of 35 degrees
    under gravity, with only 3 of the modes kept: the points' displacement Phi q + D a +
    D_rot b and the stresses (jaxflex._turning_outputs) equal an independent scipy spsolve of
    the FE system K u = -M (a + B r) written here from the node coordinates, to 1e-8 of the
    peak (two sparse solves of the same system: round-off)."""
    result = _sheet(element, n_modes=3, mesh=0.05)
    model = result.to_modal_model(points="all")
    w = np.array([0.4, -1.0, 2.5]) if "spin" in case else np.zeros(3)
    tilt = np.radians(35.0) if "tilt" in case else 0.0
    rot = axis_rotation(np.array([0.6, 0.8, 0.0]), np.array([tilt]))[0]
    g_body = rot.T @ G_WORLD
    spin = np.outer(w, w) - (w @ w) * np.eye(3)  # B of a constant spin
    system = result.system
    if element == "hex2":  # DOFs (x, y, z) per node at its layer points
        rho = system.outputs.layer.points
        field = (rho @ spin.T - g_body).reshape(-1)
    else:  # the plate's deflection DOFs move with the field's z component (a linear field)
        ones, x, y = system.outputs.linear_dofs().T
        z0 = system.outputs.z0
        field = spin[2, 0] * x + spin[2, 1] * y + (spin[2, 2] * z0 - g_body[2]) * ones
    basis = result.basis
    k_free = (basis.T @ system.K @ basis).tocsc()
    z = sla.spsolve(k_free, -(basis.T @ (system.M @ field)))
    expected = (result.observation @ z).reshape(-1, 3)
    b = spin.T.reshape(9)  # b[3 i + j] = B_ji
    inputs = _rest_inputs(model, g_body, b)
    coords = np.concatenate([inputs.q[0], inputs.base[0], b])
    shapes = np.concatenate(
        [np.asarray(model.shapes), np.asarray(model.static_residual), rotation_residual(model)],
        axis=2,
    )
    got = shapes @ coords
    scale = np.abs(expected).max()
    assert scale > 0
    assert np.abs(got - expected).max() <= 1e-8 * scale
    _, operator = system.outputs.stress_operator()
    stress = operator @ (basis @ z)
    got_stress = output_values(model, model.stress.stress, model.rotation.stress_static, inputs)
    assert np.abs(got_stress[0] - stress).max() <= 1e-8 * np.abs(stress).max()


def test_model_file_keeps_the_static_response(tmp_path):
    """Saved and read back, the model keeps its static response to the rotational loads;
    a file without it (written before) still turns the part, and the deviation, cups and
    stresses of a turning move then come with a warning that the quasi-static share of the
    modes left out is missing."""
    result = _sheet("morley", n_modes=4)
    model = result.to_modal_model(points=20)
    model.save(tmp_path / "m.npz")
    back = jaxflex.load_model(tmp_path / "m.npz")
    for name in ("static_shapes", "cup_static", "stress_static"):
        assert np.array_equal(getattr(back.rotation, name), getattr(model.rotation, name))
    old = model._replace(rotation=model.rotation.replace(cup_static=None, stress_static=None))
    old.save(tmp_path / "old.npz")
    old = jaxflex.load_model(tmp_path / "old.npz")
    assert old.rotation.cup_static is None and old.rotation.static_shapes is not None
    path, acc = _move("x", 30.0, (0.0, 0.0, 0.0))
    with pytest.warns(JaxflexWarning, match="rotational loads"):
        loads = turning_loads(old, Turn(path, acc))
    assert not loads.static_complete
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        assert turning_loads(back, Turn(path, acc)).static_complete
        simulate_turning(back, Turn(path, acc))
    older = model._replace(rotation=model.rotation.replace(static_shapes=None))
    older.save(tmp_path / "older.npz")
    older = jaxflex.load_model(tmp_path / "older.npz")
    with pytest.warns(JaxflexWarning, match="missing from the deviation"):
        simulate_turning(older, Turn(path, acc))


@pytest.mark.slow
def test_rotational_static_residual_on_the_shell_panel():
    """The curved shell panel (0.6 x 0.4 m, 1 mm, 4 cups) swivelled 90 degrees about the
    vertical at 3 rad/s: 6 kept modes against 60 (the reference, converged to well under
    0.1 % of the peak in this move), over the move and 0.2 s after. Without the static
    response to the rotational loads the 6-mode deviation misses the quasi-static share of
    the modes left out (measured 1.6 % of the peak); with it the gap falls below 0.3 %."""
    part = fem.curved_panel(0.6, 0.4, 1e-3, "steel", 0.05, element="shell")
    cups = [fem.SuctionCup(x, y, 0.03) for x in (0.15, 0.45) for y in (0.1, 0.3)]
    # no discretisation estimate (a second FE analysis): the 6 and 60 modes are compared
    # on one mesh, whatever its error
    result = fem.modal_analysis(
        part, cups, n_modes=60, zeta=0.02, progress=False, error_estimate=False
    )
    full = result.to_modal_model(points="all")
    reference = full._replace(static_shapes=None)  # the modes alone: 60 of them
    kept = full.truncate_modes(6)
    without = kept._replace(rotation=kept.rotation.replace(static_shapes=None))
    path, acc = _move("z", 90.0, (0.0, 0.0, 0.0))
    turn = Turn(path, np.zeros_like(acc))
    ref = simulate_turning(reference, turn, extend_s=0.2).deviation_m
    peak = ref.max()
    gap_with = np.abs(simulate_turning(kept, turn, extend_s=0.2).deviation_m - ref).max()
    gap_without = np.abs(simulate_turning(without, turn, extend_s=0.2).deviation_m - ref).max()
    assert gap_without > 0.01 * peak
    assert gap_with < 0.003 * peak


def _brute_force_distance(model, obstacles, path, acc, pivot, half, extend_s, refine, chunk=256):
    """The smallest skin distance at every node on a grid ``refine`` times finer than the
    move's samples, from world positions written here: the turn's angle integrated in
    closed form, the pivot's path, and the elastic displacement of every node from the
    turning response on the refined grid (the same forcing, sampled finer)."""
    n = path.n_steps
    fine_dt = DT / refine
    grid = fine_dt * np.arange(n * refine + 1)
    coarse = DT * np.arange(n + 1)
    axis = path.omega_rad_s[np.argmax(np.linalg.norm(path.omega_rad_s, axis=1))]
    axis = axis / np.linalg.norm(axis)
    alpha = np.interp(grid, coarse, path.alpha_rad_s2 @ axis)
    fine = fixed_axis_path(axis, alpha, fine_dt, start=path.rotation[0])
    fine_acc = np.column_stack([np.interp(grid, coarse, acc[:, c]) for c in range(3)])
    inputs = turning_inputs(model, Turn(fine, fine_acc, pivot_m=pivot), extend_s=extend_s)
    # u = Phi q + D a + D_rot b at every node: one product of the stacked shapes (3 K, M')
    # with the stacked coordinates, ``chunk`` rows of the grid at a time
    shapes = np.concatenate(
        [np.asarray(model.shapes), np.asarray(model.static_residual), rotation_residual(model)],
        axis=2,
    )
    shapes = shapes.reshape(-1, shapes.shape[-1])
    coords = np.concatenate([inputs.q, inputs.base, inputs.coefficients], axis=1)
    n_all = len(inputs.t_s)
    rot = np.concatenate([fine.rotation, np.repeat(fine.rotation[-1:], n_all - len(grid), 0)])
    path_pos = kinematics_at(as_move(acc, DT), inputs.t_s)[0]
    points = np.asarray(model.points)
    best = np.inf
    for begin in range(0, n_all, chunk):
        rows = slice(begin, begin + chunk)
        u = (coords[rows] @ shapes.T).reshape(-1, len(points), 3)
        local = points[None] - pivot + u
        world = pivot + path_pos[rows, None] + local @ rot[rows].transpose(0, 2, 1)
        for obstacle in obstacles:
            d, _ = obstacle.closest(world.reshape(-1, 3))
            best = min(best, float(d.min()))
    return best - half


def test_clearance_of_the_turning_part_against_brute_force():
    """A plate swivelled 90 degrees about the vertical through a pivot off its centre while
    moving 0.4 m, past a box and above a floor: the certified minimum skin distance over
    every node, the move and the settling equals the minimum of a brute-force evaluation of
    every node's world position on a grid 8 times finer than the samples, to the search's
    tolerance plus the brute force's own sampling (a point moves < 2 m/s: 1e-3 s / 8 of it
    is 0.25 mm, the bound of how far the grid minimum can lie above the true one)."""
    result = _sheet("morley", thickness=1e-3, n_modes=6, mesh=0.05)
    model = result.to_modal_model(points="all")
    path, acc = _move("z", 90.0, (0.4, 0.0, 0.0))
    pivot = np.array([0.05, 0.05, 0.0])
    obstacles = (
        Box(np.array([0.55, 0.55, 0.0]), np.array([0.1, 0.1, 0.1]), name="post"),
        HalfSpace(np.array([0.0, 0.0, 1.0]), -0.05, name="floor"),
    )
    half = 0.5e-3
    clearance = turning_min_distance(
        model, obstacles, Turn(path, acc, pivot_m=pivot), half_thickness_m=half, atol=1e-6
    )
    brute = _brute_force_distance(model, obstacles, path, acc, pivot, half, 0.3, 8)
    assert clearance.distance_m <= brute + 1e-6
    assert clearance.distance_m >= brute - 2.5e-4
    assert clearance.bound_m <= clearance.distance_m
    assert clearance.obstacle_name == "post"


def test_posed_model_keeps_the_static_response_to_the_rotational_loads():
    """The part posed in another frame (turned 40 degrees about a skew axis and shifted), at
    rest under a constant spin about a pivot: its points, cup reactions and stresses are the
    original's turned into that frame (the same physical state: w' = R w, pivot' = R c + o),
    to 1e-9 of their size (round-off of the frame change)."""
    model = _sheet("morley", n_modes=4).to_modal_model(points=30)
    rot = axis_rotation(np.array([0.2, 0.5, 0.8]) / np.linalg.norm([0.2, 0.5, 0.8]), [0.7])[0]
    offset = np.array([0.3, -0.1, 0.2])
    posed = model.posed(rot, offset)
    w, pivot = np.array([0.5, -1.2, 2.0]), np.array([0.1, 0.2, 0.0])

    def at_rest(m, w, pivot):
        spin = np.outer(w, w) - (w @ w) * np.eye(3)
        inputs = _rest_inputs(m, spin @ pivot, spin.T.reshape(9))  # a_O = -B c: no gravity
        coords = np.concatenate([inputs.q[0], inputs.base[0], inputs.coefficients[0]])
        shapes = np.concatenate(
            [np.asarray(m.shapes), np.asarray(m.static_residual), rotation_residual(m)], axis=2
        )
        cups = output_values(m, m.cups.reaction, m.rotation.cup_static, inputs)[0]
        stress = output_values(m, m.stress.stress, m.rotation.stress_static, inputs)[0]
        return shapes @ coords, cups.reshape(-1, 3), stress.reshape(-1, 6)

    points, cups, stress = at_rest(model, w, pivot)
    points_p, cups_p, stress_p = at_rest(posed, rot @ w, rot @ pivot + offset)
    voigt = voigt_rotation(rot)
    for got, want in (
        (points_p, points @ rot.T),
        (cups_p, cups @ rot.T),
        (stress_p, stress @ voigt.T),
    ):
        assert np.abs(got - want).max() <= 1e-9 * np.abs(want).max()


def _mass_moments(result):
    """(mass, int rho r (3,), int rho r r^T (3, 3)) of a thin solid from its FE mass matrix
    and node coordinates (x, y, z per node: exact for its shape functions), of a shell from
    its facets (tests/sheet_parts.sheet_moments: the 3-D sheet, fibres included)."""
    system = result.system
    if not isinstance(system.outputs, SolidOutputs):
        layer, part = system.outputs.layer, system.outputs.part
        rho_h = part.material.rho_kg_m3 * part.thickness_m
        return sheet_moments(layer.nodes, layer.triangles, rho_h, part.thickness_m)
    coords, per_node = system.outputs.layer.points, 3
    block = np.zeros((4, 4))
    for j in range(3):  # component j of the fields (r, 1)
        fields = np.zeros((system.n_dof, 4))
        fields[j::per_node, :3] = coords
        fields[j::per_node, 3] = 1.0
        block += fields.T @ (system.M @ fields)
    return block[3, 3] / 3, block[:3, 3] / 3, block[:3, :3] / 3


@pytest.mark.parametrize(
    ("part", "stiffness", "moment_rtol"),
    [
        ("plate", None, 1e-9),
        ("plate", "bellows", 1e-9),
        ("thin solid", None, 1e-9),
        # the shell's loads are its 3-D sheet's, fibres included (fem.elements.shell field_loads:
        # before, they missed them by 2e-5 of the moment)
        ("shell", None, 1e-9),
    ],
)
def test_cups_balance_the_rotational_loads_at_rest(part, stiffness, moment_rtol):
    """Held at rest under a constant field B r (an Euler and a centrifugal load, no gravity)
    with 4 modes kept, the cup reactions (rigid or compliant bellows cups) balance the part's
    inertia: forces sum to B (m c) and their moments about the origin to eps_kab B_bc
    Sigma_ac, Sigma = int rho r r^T (:func:`_mass_moments`; the flat plate's in closed form:
    it has no in-plane DOFs), to 1e-9 (one sparse solve's round-off)."""
    builders = {
        "plate": lambda: fem.rectangular_plate(0.6, 0.4, 1e-3, "steel", 0.05),
        "thin solid": lambda: fem.curved_panel(0.6, 0.4, 1e-3, "steel", 0.1),
        "shell": lambda: fem.curved_panel(0.6, 0.4, 1e-3, "steel", 0.05, element="shell"),
    }
    cups = [
        fem.SuctionCup(x, y, 0.03, stiffness=stiffness) for x in (0.15, 0.45) for y in (0.1, 0.3)
    ]
    result = fem.modal_analysis(builders[part](), cups, n_modes=4, zeta=0.02, progress=False)
    model = result.to_modal_model(points=10)
    if part == "plate":
        z0 = float(result.system.nodes[0, 2])
        mass = 7850.0 * 0.6 * 0.4 * 1e-3
        first = mass * np.array([0.3, 0.2, z0])
        second = mass * np.array(
            [[0.12, 0.06, 0.3 * z0], [0.06, 0.4**2 / 3, 0.2 * z0], [0.3 * z0, 0.2 * z0, z0**2]]
        )
    else:
        mass, first, second = _mass_moments(result)
    w, alpha = np.array([0.3, -0.5, 1.0]), np.array([2.0, 1.0, -3.0])
    b_matrix = _skew(alpha) + np.outer(w, w) - (w @ w) * np.eye(3)
    inputs = _rest_inputs(model, np.zeros(3), b_matrix.T.reshape(9))
    reactions = output_values(model, model.cups.reaction, model.rotation.cup_static, inputs)
    reactions = reactions[0].reshape(-1, 6)
    cup_centres = np.asarray(model.cups.centre_m)
    force = reactions[:, :3].sum(axis=0)
    moment = (reactions[:, 3:] + np.cross(cup_centres, reactions[:, :3])).sum(axis=0)
    assert np.abs(force - b_matrix @ first).max() <= 1e-9 * np.abs(force).max()
    eps = np.zeros((3, 3, 3))
    for k, i, j in ((0, 1, 2), (1, 2, 0), (2, 0, 1)):
        eps[k, i, j], eps[k, j, i] = 1.0, -1.0
    expected = np.einsum("kab,bc,ac->k", eps, b_matrix, second)
    assert np.abs(moment - expected).max() <= moment_rtol * np.abs(expected).max()
