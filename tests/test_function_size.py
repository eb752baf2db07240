"""The house rule of the optimiser and the sizing (docs/design.md, Conventions): no function
longer than 80 lines or with more than 8 parameters, except the public entry points listed
here, which only gather one keyword option per command-line option into a checked request;
and in the FMU layer and the sizing no function at all over 80 lines or 10 parameters (the
long option lists are option objects: fmu.Fmi, fmu.CellOutputs, fmu.Turning, fem.Accuracy)."""

from __future__ import annotations

import ast
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
MAX_LINES, MAX_PARAMETERS = 80, 8
ENTRY_POINTS = {  # (file, function): why it may take more
    ("optim/optimize.py", "optimize"): "public: one keyword per `jaxflex optimize` option",
    ("optim/baselines.py", "baselines"): "public: the baselines of a move still to be found",
    ("optim/sweep/run.py", "run_sweep"): "public: one keyword per `jaxflex sweep` option",
    ("fem/sizing/run.py", "size_model"): "public: the part, move, threshold, fem.Accuracy, ...",
}


def _functions(folders=("optim", "fem/sizing")):
    files = [path for folder in folders for path in sorted((ROOT / folder).rglob("*.py"))]
    for path in files:
        for node in ast.walk(ast.parse(path.read_text())):
            if isinstance(node, ast.FunctionDef | ast.AsyncFunctionDef):
                args = node.args
                names = [a.arg for a in (*args.posonlyargs, *args.args, *args.kwonlyargs)]
                names = [n for n in names if n not in ("self", "cls")]
                lines = node.end_lineno - node.lineno + 1
                yield str(path.relative_to(ROOT)), node.name, lines, len(names)


def test_functions_are_short_and_take_few_parameters():
    over = [
        f"{file}:{name} ({lines} lines, {count} parameters)"
        for file, name, lines, count in _functions()
        if (lines > MAX_LINES or count > MAX_PARAMETERS) and (file, name) not in ENTRY_POINTS
    ]
    assert not over, "split these or list them as entry points with a reason: " + ", ".join(over)


def test_listed_entry_points_exist():
    found = {(file, name) for file, name, _, _ in _functions()}
    assert set(ENTRY_POINTS) <= found


def test_no_function_of_the_fmu_layer_or_the_sizing_is_long_or_takes_many_parameters():
    """Issue 36's target for fmu/ and fem/sizing: at most 80 lines and 10 parameters, public
    or not, with no exception."""
    over = [
        f"{file}:{name} ({lines} lines, {count} parameters)"
        for file, name, lines, count in _functions(("fmu", "fem/sizing"))
        if lines > MAX_LINES or count > 10
    ]
    assert not over, "split these or gather their options into an option object: " + ", ".join(over)
