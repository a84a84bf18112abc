# The attributes dict: what files carry comes back as typed NumPy columns, goes back into
# files bit for bit, and rides through the algorithms as the tool carries it.
import numpy as np
import pytest

import idas


def test_obj_uv_round_trip(data, cli, tmp_path):
    v, f, a = idas.read(data / "blub.obj")
    uv = a["uv"]
    assert uv["domain"] == "corner"
    assert uv["values"].dtype == np.float64 and uv["values"].shape == (3 * len(f), 2)
    assert a["header_lines"] == {"domain": "file", "lines": ["mtllib ./blub.mtl"]}
    idas.write(tmp_path / "module.obj", v, f, a)
    cli("convert", data / "blub.obj", tmp_path / "cli.obj")
    assert (tmp_path / "module.obj").read_bytes() == (tmp_path / "cli.obj").read_bytes()
    v2, f2, a2 = idas.read(tmp_path / "module.obj")
    assert np.array_equal(v2, v) and np.array_equal(f2, f)
    assert np.array_equal(a2["uv"]["values"], uv["values"])


def test_decimate_carries_uv_as_cli(data, cli, tmp_path):
    cli("decimate", data / "blub.obj", tmp_path / "cli.obj", "--ratio", 0.2)
    v, f, a = idas.read(data / "blub.obj")
    dv, df, da = idas.decimate(v, f, a, ratio=0.2)
    assert da["uv"]["values"].shape == (3 * len(df), 2)
    idas.write(tmp_path / "module.obj", dv, df, da)
    assert (tmp_path / "module.obj").read_bytes() == (tmp_path / "cli.obj").read_bytes()


def test_typed_ply_columns(data, tmp_path):
    v, f, _ = idas.read(data / "bunny.off")
    rng = np.random.default_rng(7)
    confidence = rng.integers(0, 256, size=len(v), dtype=np.uint8)
    quality = rng.random(len(f)).astype(np.float32)
    part = rng.integers(-5, 5, size=len(f), dtype=np.int16)
    attributes = {
        "confidence": {"domain": "vertex", "values": confidence},
        "quality": {"domain": "face", "values": quality},
        "part": {"domain": "face", "values": part},
    }
    for ascii in (False, True):
        idas.write(tmp_path / "typed.ply", v, f, attributes, ascii=ascii)
        _, _, back = idas.read(tmp_path / "typed.ply")
        for name, column in attributes.items():
            assert back[name]["domain"] == column["domain"]
            assert back[name]["values"].dtype == column["values"].dtype
            assert np.array_equal(back[name]["values"], column["values"])


def test_same_name_in_two_domains(data, tmp_path):
    v, f, _ = idas.read(data / "bunny.off")
    attributes = {
        "q1": {"name": "quality", "domain": "vertex", "values": np.arange(len(v), dtype=np.int32)},
        "q2": {"name": "quality", "domain": "face", "values": np.arange(len(f), dtype=np.int32)},
    }
    idas.write(tmp_path / "two.ply", v, f, attributes)
    _, _, back = idas.read(tmp_path / "two.ply")
    assert set(back) == {"vertex:quality", "face:quality"}
    assert back["face:quality"]["name"] == "quality"
    assert np.array_equal(back["face:quality"]["values"], np.arange(len(f)))


def test_unstored_attribute_warns(data, tmp_path):
    v, f, a = idas.read(data / "blub.obj")
    with pytest.warns(UserWarning, match="cannot store these attributes.*uv"):
        idas.write(tmp_path / "plain.off", v, f, a)
    assert idas.read(tmp_path / "plain.off")[2] == {}


def test_tet_fields_round_trip(bunny, tmp_path):
    v, t, _ = idas.harmonic(bunny[0][:500], mode="reduced")
    fields = {
        "quality": {"domain": "tet", "values": np.linspace(0, 1, len(t))},
        "displacement": {"domain": "vertex", "values": 2 * v},
    }
    tags = {"tag": {"domain": "tet", "values": (np.arange(len(t)) % 3 + 1).astype(np.int32)}}
    # MSH 4.1 groups tets by tag (one volume entity each): tags are checked on 2.2.
    for version, attributes in (("2.2", {**fields, **tags}), ("4.1", fields)):
        idas.write(tmp_path / "fields.msh", v, t, attributes, msh_version=version)
        rv, rt, back = idas.read(tmp_path / "fields.msh")
        assert np.array_equal(rv, v) and np.array_equal(rt, t)
        assert set(back) == set(attributes)
        for name, column in attributes.items():
            assert back[name]["domain"] == column["domain"]
            assert np.array_equal(back[name]["values"], column["values"])


def test_vtu_keeps_vertex_fields_and_says_what_it_drops(bunny, tmp_path):
    v, t, _ = idas.harmonic(bunny[0][:200], mode="reduced")
    attributes = {
        "tag": {"domain": "tet", "values": np.ones(len(t), np.int32)},
        "pressure": {"domain": "vertex", "values": v[:, 0].copy()},
    }
    with pytest.warns(UserWarning, match=r"cannot store these attributes.*tag \(tet\)"):
        idas.write(tmp_path / "out.vtu", v, t, attributes, ascii=True)
    assert 'Name="pressure"' in (tmp_path / "out.vtu").read_text()
