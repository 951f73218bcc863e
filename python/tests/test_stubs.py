"""The type stubs describe the runtime: every stubbed function and method exists with the same
parameters (names, order, kinds, which have defaults), every public runtime name has a stub, and
paths are typed as ``os.PathLike`` wherever the runtime accepts one. mypy --strict checks a
sample script against the stubs when mypy is installed."""

import ast
import inspect
import shutil
import subprocess
import sys
import textwrap
from pathlib import Path

import pytest

import isogrid
from isogrid import _isogrid

STUBS = Path(isogrid.__file__).parent / "_isogrid.pyi"
SKIPPED_PARAMS = {"self", "cls"}


def stub_tree():
    return ast.parse(STUBS.read_text())


def stub_params(fn: ast.FunctionDef):
    """[(name, kind, has_default)] of a stubbed function, without self/cls."""
    a = fn.args
    out = []
    positional = a.posonlyargs + a.args
    defaults = [None] * (len(positional) - len(a.defaults)) + list(a.defaults)
    for arg, default in zip(positional, defaults):
        kind = "POSITIONAL_ONLY" if arg in a.posonlyargs else "POSITIONAL_OR_KEYWORD"
        out.append((arg.arg, kind, default is not None))
    if a.vararg:
        out.append((a.vararg.arg, "VAR_POSITIONAL", False))
    for arg, default in zip(a.kwonlyargs, a.kw_defaults):
        out.append((arg.arg, "KEYWORD_ONLY", default is not None))
    if a.kwarg:
        out.append((a.kwarg.arg, "VAR_KEYWORD", False))
    return [p for p in out if p[0] not in SKIPPED_PARAMS]


def runtime_params(obj):
    sig = inspect.signature(obj)
    return [
        (p.name, p.kind.name, p.default is not inspect.Parameter.empty)
        for p in sig.parameters.values()
        if p.name not in SKIPPED_PARAMS
    ]


def stubbed():
    """(qualified name, runtime object, stub FunctionDef) for every stubbed callable."""
    out = []
    for node in stub_tree().body:
        if isinstance(node, ast.FunctionDef):
            out.append((node.name, getattr(_isogrid, node.name, None), node))
        elif isinstance(node, ast.ClassDef):
            cls = getattr(_isogrid, node.name, None)
            for item in node.body:
                if isinstance(item, ast.FunctionDef):
                    is_property = any(
                        isinstance(d, ast.Name) and d.id == "property" for d in item.decorator_list
                    )
                    target = cls if item.name != "__new__" else cls
                    out.append((f"{node.name}.{item.name}", (target, item.name, is_property), item))
    return out


@pytest.mark.parametrize("name,runtime,stub", stubbed(), ids=lambda x: x if isinstance(x, str) else "")
def test_stub_matches_runtime_signature(name, runtime, stub):
    if isinstance(runtime, tuple):
        cls, attr, is_property = runtime
        assert cls is not None, f"{name}: class missing at runtime"
        if is_property:
            assert isinstance(inspect.getattr_static(cls, attr), property) or inspect.isgetsetdescriptor(
                inspect.getattr_static(cls, attr)
            ), f"{name} is not a property at runtime"
            return
        if attr == "__new__":
            obj = cls  # the constructor's signature is the class's
        else:
            obj = getattr(cls, attr, None)
        assert obj is not None, f"{name} missing at runtime"
        if attr == "__reduce__":
            return  # inherited from object's protocol; no text signature to compare
    else:
        obj = runtime
        assert obj is not None, f"{name} missing at runtime"
    assert runtime_params(obj) == stub_params(stub), name


def test_every_public_runtime_name_is_stubbed():
    names = {n.name for n in stub_tree().body if isinstance(n, (ast.FunctionDef, ast.ClassDef))}
    names |= {
        t.id
        for n in stub_tree().body
        if isinstance(n, ast.AnnAssign) and isinstance(n.target, ast.Name)
        for t in [n.target]
    }
    public = {n for n in dir(_isogrid) if not n.startswith("_")} | {"__version__"}
    assert public - names == set()
    methods = {n.name for c in stub_tree().body if isinstance(c, ast.ClassDef) and c.name == "CellGrid" for n in c.body if isinstance(n, ast.FunctionDef)}
    runtime_methods = {n for n in dir(_isogrid.CellGrid) if not n.startswith("_")}
    assert runtime_methods - methods == set()


def test_paths_are_typed_path_like(tmp_path):
    for _, _, stub in stubbed():
        for arg in stub.args.args:
            if arg.arg == "path":
                assert "_Path" in ast.unparse(arg.annotation), f"{stub.name}: {ast.unparse(arg.annotation)}"
    # And the runtime does take a Path wherever the stubs say so.
    grid = isogrid.extract(__import__("numpy").ones((3, 3, 3), dtype="uint8") * [[[0, 1, 2]]], iso=1)
    grid.save(tmp_path / "p.cgc")
    assert _isogrid.load(tmp_path / "p.cgc").active_cells == grid.active_cells


SAMPLE = textwrap.dedent(
    """
    from pathlib import Path

    import numpy as np

    import isogrid
    from isogrid.skimage import marching_cubes

    volume = np.zeros((8, 8, 8), dtype=np.float32)
    volume[2:6, 2:6, 2:6] = 1.0
    grid: isogrid.CellGrid = isogrid.extract(volume, iso=0.5)
    grid.save(Path("out.cgc"))
    again = isogrid.load(Path("out.cgc"))
    data: bytes = again.to_bytes()
    copy = isogrid.CellGrid(data)
    n: int = copy.active_cells
    verts, faces = isogrid.marching_cubes(volume, iso=0.5)
    sk_verts, sk_faces, normals, values = marching_cubes(volume, 0.5, spacing=(1.0, 2.0, 1.0))
    loaded = isogrid.load_volume(Path("v.npy"))
    print(n, verts.shape, sk_verts.shape, loaded.spacing)
    """
)


def test_mypy_strict_accepts_a_sample_script(tmp_path):
    if shutil.which("mypy") is None and subprocess.run(
        [sys.executable, "-m", "mypy", "--version"], capture_output=True
    ).returncode != 0:
        pytest.skip("mypy is not installed")
    script = tmp_path / "sample.py"
    script.write_text(SAMPLE)
    out = subprocess.run(
        [sys.executable, "-m", "mypy", "--strict", "--no-incremental", str(script)],
        capture_output=True,
        text=True,
        cwd=tmp_path,
    )
    assert out.returncode == 0, out.stdout + out.stderr
