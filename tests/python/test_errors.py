# Bad files, bad arrays and absurd options raise exceptions that say what is wrong and
# where; nothing crashes.
import numpy as np
import pytest

import idas


def test_missing_file(tmp_path):
    with pytest.raises(FileNotFoundError, match="nothing.obj"):
        idas.read(tmp_path / "nothing.obj")


def refuses_file(path, text, match):
    path.write_text(text)
    with pytest.raises(idas.InputError, match=match):
        idas.read(path)


def test_broken_files(tmp_path):
    refuses_file(tmp_path / "bad.off", "OFF\n3 1 0\n0 0 0\n1 0 0\n", "bad.off")
    refuses_file(tmp_path / "index.obj", "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 7\n",
                 "index.obj.*line 4")
    refuses_file(tmp_path / "points.xyz123", "0 0 0\n", "points.xyz123")
    refuses_file(tmp_path / "empty.obj", "v 0 0 0\n", "empty.obj: the file contains no triangles")
    assert issubclass(idas.InputError, ValueError)


def test_non_manifold_input(data):
    v, f, _ = idas.read(data / "edge_with_four_triangles.off")
    with pytest.raises(idas.InputError, match="mesh: .*manifold"):
        idas.decimate(v, f, ratio=0.5)


def test_bad_arrays(bunny):
    v, f = bunny
    with pytest.raises(ValueError, match=r"vertices must have shape \(n, 3\)"):
        idas.decimate(v[:, :2], f, ratio=0.5)
    with pytest.raises(ValueError, match="faces must hold integers"):
        idas.decimate(v, f.astype(np.float64), ratio=0.5)
    with pytest.raises(ValueError, match=r"faces\[5\] references vertex 3485"):
        g = f.copy()
        g[5, 1] = len(v)
        idas.decimate(v, g, ratio=0.5)
    with pytest.raises(ValueError, match=r"faces\[0\] references vertex -1"):
        idas.remesh(v, np.vstack([[-1, 0, 1], f]))
    with pytest.raises(ValueError, match=r"faces\[2\] repeats vertex"):
        g = f.copy()
        g[2, 2] = g[2, 0]
        idas.info(v, g)
    with pytest.raises(ValueError, match="vertices must hold numbers"):
        idas.info(np.array([["a", "b", "c"]]), f[:0])
    with pytest.raises(ValueError, match="faces is empty"):
        idas.decimate(v, f[:0], ratio=0.5)
    w = v.copy()
    w[0, 0] = np.nan
    with pytest.raises(ValueError, match="vertices: "):
        idas.remesh(w, f)


def test_bad_attributes(bunny, tmp_path):
    v, f = bunny
    with pytest.raises(ValueError, match=r"attributes\['c'\]: a vertex attribute needs 3485 rows"):
        idas.decimate(v, f, {"c": {"domain": "vertex", "values": np.zeros(10)}}, ratio=0.5)
    with pytest.raises(ValueError, match="dtype int64"):
        idas.write(tmp_path / "x.ply", v, f, {"c": {"domain": "face", "values": np.zeros(len(f), np.int64)}})
    with pytest.raises(ValueError, match="domain must be"):
        idas.write(tmp_path / "x.ply", v, f, {"c": {"domain": "edge", "values": np.zeros(len(f))}})
    with pytest.raises(ValueError, match="must be a dict"):
        idas.write(tmp_path / "x.ply", v, f, {"c": np.zeros(len(f))})


def test_absurd_options(bunny, tmp_path):
    v, f = bunny
    with pytest.raises(idas.InputError, match=r"^ratio must be in \(0, 1\]"):
        idas.decimate(v, f, ratio=1.5)
    with pytest.raises(ValueError, match="exactly one of ratio or target_faces"):
        idas.decimate(v, f, ratio=0.5, target_faces=10)
    with pytest.raises(idas.InputError, match="target_faces must be non-negative"):
        idas.decimate(v, f, target_faces=-3)
    with pytest.raises(idas.InputError, match="threads must be between 1 and 1024"):
        idas.decimate(v, f, ratio=0.5, threads=0)
    with pytest.raises(idas.InputError, match="algorithm must be"):
        idas.decimate(v, f, ratio=0.5, algorithm="fast")
    with pytest.raises(idas.InputError, match="backend must be"):
        idas.remesh(v, f, backend="halfedge")
    with pytest.raises(idas.InputError, match="feature_angle must be between"):
        idas.remesh(v, f, feature_angle=200)
    with pytest.raises(idas.InputError, match="edge_length must be a positive"):
        idas.remesh(v, f, edge_length=-1)
    with pytest.raises(idas.InputError, match="more than max_faces"):
        idas.remesh(v, f, edge_length=1e-6)
    with pytest.raises(idas.InputError, match="stop_energy must be"):
        idas.tetmesh(v, f, stop_energy=1)
    with pytest.raises(idas.InputError, match="mode must be"):
        idas.harmonic(v, mode="fast")
    with pytest.raises(ValueError, match="at least 4 points"):
        idas.harmonic(v[:3])
    with pytest.raises(idas.InputError, match="unknown"):
        idas.write(tmp_path / "out.abc", v, f)
    with pytest.raises(ValueError, match=r"tets must have shape \(m, 4\)"):
        idas.write(tmp_path / "out.msh", v, f)
