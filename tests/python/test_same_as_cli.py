# The module and the idas tool give the same output for the same input and options: the
# files written are byte for byte the same.
import json

import numpy as np

import idas


def same_bytes(a, b):
    return a.read_bytes() == b.read_bytes()


def test_read_bunny(data):
    v, f, attributes = idas.read(data / "bunny.off")
    assert v.shape == (3485, 3) and v.dtype == np.float64
    assert f.shape == (6966, 3) and f.dtype == np.int64
    assert f.min() == 0 and f.max() == 3484
    assert attributes == {}


def test_decimate_as_cli(data, cli, tmp_path):
    cli("decimate", data / "bunny.off", tmp_path / "cli.off", "--ratio", 0.1)
    v, f, _ = idas.read(data / "bunny.off")
    dv, df, da = idas.decimate(v, f, ratio=0.1)
    assert df.shape[1] == 3 and len(df) <= 697  # target round(0.1 * 6966)
    idas.write(tmp_path / "module.off", dv, df, da)
    assert same_bytes(tmp_path / "cli.off", tmp_path / "module.off")


def test_decimate_deterministic_two_threads_as_cli(data, cli, tmp_path):
    cli("decimate", data / "bunny.off", tmp_path / "cli.ply", "--faces", 1000,
        "--algorithm", "shortest-edge", "--threads", 2, "--deterministic")
    v, f, _ = idas.read(data / "bunny.off")
    dv, df, da = idas.decimate(v, f, target_faces=1000, algorithm="shortest-edge", threads=2,
                               deterministic=True)
    idas.write(tmp_path / "module.ply", dv, df, da)
    assert same_bytes(tmp_path / "cli.ply", tmp_path / "module.ply")
    # Deterministic rounds: one thread gives the same mesh.
    one = idas.decimate(v, f, target_faces=1000, algorithm="shortest-edge", threads=1,
                        deterministic=True)
    assert np.array_equal(one[0], dv) and np.array_equal(one[1], df)


def test_remesh_as_cli(data, cli, tmp_path):
    cli("remesh", data / "bunny.off", tmp_path / "cli.obj", "--edge-length", 0.03,
        "--iterations", 3)
    v, f, _ = idas.read(data / "bunny.off")
    rv, rf, ra = idas.remesh(v, f, edge_length=0.03, iterations=3)
    idas.write(tmp_path / "module.obj", rv, rf, ra)
    assert same_bytes(tmp_path / "cli.obj", tmp_path / "module.obj")


def test_harmonic_as_cli(data, cli, tmp_path):
    v, _, _ = idas.read(data / "bunny.off")
    np.savetxt(tmp_path / "bunny.xyz", v, fmt="%.17g")  # exact round trip
    cli("harmonic", tmp_path / "cli.msh", "--points", tmp_path / "bunny.xyz", "--mode",
        "reduced")
    hv, ht, ha = idas.harmonic(v, mode="reduced")
    assert ht.shape[1] == 4 and ha == {}
    idas.write(tmp_path / "module.msh", hv, ht, ha)  # MSH 4.1 binary, as the tool
    assert same_bytes(tmp_path / "cli.msh", tmp_path / "module.msh")


def test_tetmesh_as_cli(data, cli, tmp_path):
    cli("tetmesh", data / "sphere.obj", tmp_path / "cli.msh", "--max-iterations", 3)
    v, f, _ = idas.read(data / "sphere.obj")
    tv, tt, ta = idas.tetmesh(v, f, max_iterations=3)
    assert set(np.unique(ta["tag"]["values"])) == {1}  # the inside only
    idas.write(tmp_path / "module.msh", tv, tt, ta, msh_version="2.2")
    assert same_bytes(tmp_path / "cli.msh", tmp_path / "module.msh")
    # And read back as the tool wrote it.
    rv, rt, ra = idas.read(tmp_path / "cli.msh")
    assert np.array_equal(rv, tv) and np.array_equal(rt, tt)
    assert "tag" not in ra  # all 1: the reader leaves them implicit
    expected = json.loads(cli("info", tmp_path / "cli.msh", "--json"))
    del expected["seconds"]
    assert idas.info(tmp_path / "cli.msh") == expected
    from_arrays = idas.info(tv, tt)
    assert from_arrays.pop("file") is None and expected.pop("file")
    assert from_arrays == expected
    assert expected["tets"] == len(tt) and expected["inverted_tets"] == 0


def test_tetmesh_deterministic_two_threads_as_cli(data, cli, tmp_path):
    cli("tetmesh", data / "sphere.obj", tmp_path / "cli.msh", "--max-iterations", 2,
        "--deterministic")
    v, f, _ = idas.read(data / "sphere.obj")
    tv, tt, ta = idas.tetmesh(v, f, max_iterations=2, deterministic=True, threads=2)
    idas.write(tmp_path / "module.msh", tv, tt, ta, msh_version="2.2")
    assert same_bytes(tmp_path / "cli.msh", tmp_path / "module.msh")


def test_decimate_attribute_weight_as_cli(data, cli, tmp_path):
    cli("decimate", data / "blub.obj", tmp_path / "cli.obj", "--ratio", 0.1,
        "--attribute-weight", 0.5)
    v, f, a = idas.read(data / "blub.obj")
    dv, df, da = idas.decimate(v, f, a, ratio=0.1, attribute_weight=0.5)
    idas.write(tmp_path / "module.obj", dv, df, da)
    assert same_bytes(tmp_path / "cli.obj", tmp_path / "module.obj")
    # The weight changes the result, and a bad one is refused like the tool's.
    idas.write(tmp_path / "zero.obj", *idas.decimate(v, f, a, ratio=0.1, attribute_weight=0))
    assert not same_bytes(tmp_path / "zero.obj", tmp_path / "module.obj")
    try:
        idas.decimate(v, f, a, ratio=0.1, attribute_weight=-1)
    except idas.InputError as e:
        assert "attribute_weight" in str(e)
    else:
        raise AssertionError("a negative attribute_weight was accepted")


def test_info_as_cli(data, cli):
    expected = json.loads(cli("info", data / "bunny.off", "--json", "--self-intersections"))
    del expected["seconds"], expected["phases"]
    assert idas.info(data / "bunny.off", self_intersections=True) == expected
    v, f, _ = idas.read(data / "bunny.off")
    from_arrays = idas.info(v, f, self_intersections=True)
    assert from_arrays.pop("file") is None
    expected.pop("file")
    assert from_arrays == expected
    assert expected["genus"] == 0 and expected["self_intersections"] == 0
