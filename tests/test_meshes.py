"""Mesh readers (vrlab.render.meshes) against what Mitsuba 3 (scalar_rgb) loads from the
same files: vertex positions, faces, normals, uvs and mesh attributes, plus bad files."""
from __future__ import annotations

import struct
import zlib

import numpy as np
import pytest

from vrlab.render.meshes import (MeshData, read_mesh, read_obj, read_ply, read_serialized,
                                 vertex_normals, write_ply, write_serialized)

mi = pytest.importorskip("mitsuba")
mi.set_variant("scalar_rgb")

pytestmark = pytest.mark.filterwarnings("ignore:.*PLY vertex properties ignored:UserWarning")

TOL = 1e-6          # Mitsuba stores float32; the test values are exact in float32 or close

# A small closed-ish mesh: 6 vertices, a quad, a pentagon and triangles.
POS = np.array([[0, 0, 0], [1, 0, 0], [1.5, 1, 0.25], [0, 1, 0], [0.5, 0.5, 1], [2, 0.5, 0.5]])
UV = np.array([[0, 0], [1, 0], [1, 1], [0, 1], [0.5, 0.25], [0.75, 0.125]])
NRM = np.array([[0, 0, 1], [0, 1, 1], [1, 0, 0], [0, 0, 2], [1, 1, 1], [0, -1, 0]])
POLYS = [[0, 1, 2, 3], [0, 1, 4], [1, 5, 2, 4, 3], [3, 2, 4]]


def mitsuba_mesh(kind: str, path, **params) -> dict:
    """Mitsuba's buffers of a shape loaded from ``path`` as (n, k) arrays."""
    shape = mi.load_dict({"type": kind, "filename": str(path), **params})
    p = mi.traverse(shape)
    out = {"vertices": np.array(p["vertex_positions"]).reshape(-1, 3),
           "faces": np.array(p["faces"]).reshape(-1, 3)}
    n, uv = np.array(p["vertex_normals"]), np.array(p["vertex_texcoords"])
    out["normals"] = n.reshape(-1, 3) if n.size else None
    out["uvs"] = uv.reshape(-1, 2) if uv.size else None
    for k in p.keys():
        if k.startswith(("vertex_", "face_")) and k not in (
                "vertex_positions", "vertex_normals", "vertex_texcoords"):
            rows = len(out["vertices"]) if k.startswith("vertex_") else len(out["faces"])
            out[k] = np.array(p[k]).reshape(rows, -1)
    return out


def assert_same(ours: MeshData, theirs: dict, attributes=()):
    assert ours.vertices.shape == theirs["vertices"].shape
    np.testing.assert_allclose(ours.vertices, theirs["vertices"], atol=TOL)
    np.testing.assert_array_equal(ours.faces, theirs["faces"])
    for key in ("normals", "uvs"):
        a, b = getattr(ours, key), theirs[key]
        assert (a is None) == (b is None), key
        if a is not None:
            np.testing.assert_allclose(a, b, atol=TOL, err_msg=key)
    for key in attributes:
        a = {**ours.vertex_attributes, **ours.face_attributes}[key]
        np.testing.assert_allclose(a, theirs[key], atol=TOL, err_msg=key)


def obj_text(form: str = "v/vt/vn", negative: bool = False) -> str:
    """OBJ whose corners all have the given form, with a quad, a pentagon, a face whose
    later corners omit vt/vn, comments and the lines Mitsuba ignores; only the vt/vn
    lines the form uses are written (Mitsuba leaves the buffers of absent ones
    uninitialised).  ``negative`` writes the same faces with relative indices."""
    has_t, has_n = "vt" in form, "vn" in form
    lines = ["# test mesh", "mtllib scene.mtl", "o thing", "g group"]
    lines += [f"v {x:g} {y:g} {z:g}" for x, y, z in POS[:4]]
    lines += [f"vt {u:g} {v:g}" for u, v in UV] if has_t else []
    lines += [f"vn {x:g} {y:g} {z:g}" for x, y, z in NRM] if has_n else []
    lines += ["usemtl red", "s 1"]
    lines += [f"  v {x:g} {y:g} {z:g} 1.0   # with w" for x, y, z in POS[4:]]

    def ref(i: int) -> str:             # all 6 v, vt, vn are defined above the faces
        return str(i - 6) if negative else str(i + 1)

    def corner(i: int, t: int, n: int) -> str:
        return ref(i) + (f"/{ref(t) if has_t else ''}" if has_t or has_n else "") \
            + (f"/{ref(n)}" if has_n else "")
    faces = [[corner(i, i, i) for i in POLYS[0]],
             [corner(i, i, (i + 1) % 6) for i in POLYS[1]],
             [corner(i, (i + 2) % 6, i) for i in POLYS[2]],
             # corners 2 and 3 omit vt/vn: Mitsuba 3.9.1 reuses those of corner 1
             [corner(3, 5, 4), ref(2), ref(4)]]
    lines += ["f " + " ".join(faces[0]), "f " + " ".join(faces[1])]
    lines += ["f\t" + "\t".join(faces[2]) + "  # pentagon", "l 1 2", "f " + " ".join(faces[3])]
    return "\n".join(lines) + "\n"


@pytest.mark.parametrize("form", ["v/vt/vn", "v//vn", "v/vt"])
@pytest.mark.parametrize("params", [{}, {"flip_tex_coords": False}, {"face_normals": True}])
def test_obj_matches_mitsuba(tmp_path, form, params):
    path = tmp_path / "mesh.obj"
    path.write_text(obj_text(form))
    ours = read_obj(path, **params)
    assert (ours.normals is None) == ("vn" not in form or "face_normals" in params)
    assert (ours.uvs is None) == ("vt" not in form)
    if "face_normals" not in params:
        ours = ours.with_vertex_normals()     # Mitsuba computes them when there are none
    assert_same(ours, mitsuba_mesh("obj", path, **params))
    assert ours.face_count == 2 + 1 + 3 + 1 and ours.name == "mesh.obj"


def test_obj_negative_indices_and_crlf(tmp_path):
    """Relative indices (which Mitsuba 3.9.1 rejects) and CRLF line ends give the mesh
    that Mitsuba loads from the positive-index LF file."""
    pos, neg = tmp_path / "pos.obj", tmp_path / "neg.obj"
    pos.write_text(obj_text())
    neg.write_bytes(obj_text(negative=True).replace("\n", "\r\n").encode())
    ours = read_obj(neg)
    assert ours.vertex_count == 15
    assert_same(ours, mitsuba_mesh("obj", pos))


def test_obj_corners_missing_vt_vn(tmp_path):
    """Where some corners name vt/vn and others do not (Mitsuba 3.9.1 leaves those
    uninitialised), the others get uv (0, 0) and the computed vertex normal."""
    path = tmp_path / "mixed.obj"
    path.write_text("v 0 0 0\nv 1 0 0\nv 0 1 0\nv 1 1 1\nvt 0.5 0.25\nvn 0 0 3\n"
                    "f 1/1/1 2/1/1 3/1/1\nf 2 4 3\n")
    mesh = read_obj(path)
    np.testing.assert_allclose(mesh.uvs, [[0.5, 0.75]] * 3 + [[0, 0]] * 3)
    np.testing.assert_allclose(mesh.normals[:3], [[0, 0, 1]] * 3)
    np.testing.assert_allclose(mesh.normals[3:], vertex_normals(mesh.vertices, mesh.faces)[3:])


def test_computed_normals_match_mitsuba(tmp_path):
    """Without vn lines Mitsuba computes angle-weighted vertex normals; so does
    with_vertex_normals (an irregular mesh where area or uniform weights differ)."""
    path = tmp_path / "bare.obj"
    path.write_text("".join(f"v {x:g} {y:g} {z:g}\n" for x, y, z in POS)
                    + "".join("f " + " ".join(str(i + 1) for i in p) + "\n" for p in POLYS)
                    + "f 1 4 5\nf 2 6 5\n")
    ours = read_obj(path)
    assert ours.normals is None
    assert_same(ours.with_vertex_normals(), mitsuba_mesh("obj", path))


def ply_ascii(polys=None) -> str:
    polys = POLYS[1:2] + [[0, 1, 2], [0, 2, 3], [3, 2, 4]] if polys is None else polys
    head = ["ply", "format ascii 1.0", "comment vrlab test", f"element vertex {len(POS)}"]
    head += [f"property float {c}" for c in ("x", "y", "z", "nx", "ny", "nz", "s", "t")]
    head += ["property float red", "property float green", "property float blue",
             "property float alpha", "property float temp_x", "property double dir_x",
             "property double dir_y", "property double dir_z", "property float pair_x",
             "property float pair_y", f"element face {len(polys)}",
             "property list uchar int vertex_indices", "property float id_x",
             "element extra 2", "property float q", "end_header"]
    rows = [" ".join(f"{x:g}" for x in (*POS[i], *NRM[i], *UV[i], i / 8, 0.5, 1 - i / 8,
                                         0.25, i, i, 2 * i, 3 * i, 5, 6))
            for i in range(len(POS))]
    rows += [f"{len(p)} {' '.join(map(str, p))} {k}" for k, p in enumerate(polys)]
    return "\n".join(head + rows + ["7", "8"]) + "\n"


PLY_ATTRS = ("vertex_color", "vertex_temp", "vertex_dir", "face_id")


@pytest.mark.parametrize("params", [{}, {"flip_tex_coords": True}, {"face_normals": True}])
def test_ply_ascii_matches_mitsuba(tmp_path, params):
    """Also Mitsuba's attribute grouping: red/green/blue/alpha -> vertex_color (4),
    temp_x -> vertex_temp (1), dir_x/y/z -> vertex_dir (3), a 2-field group ignored."""
    path = tmp_path / "mesh.ply"
    path.write_text(ply_ascii())
    with pytest.warns(UserWarning, match="pair_x/pair_y"):
        ours = read_ply(path, **params)
    theirs = mitsuba_mesh("ply", path, **params)
    attrs = {**ours.vertex_attributes, **ours.face_attributes}
    assert sorted(attrs) == sorted(PLY_ATTRS) == sorted(set(theirs) - {
        "vertices", "faces", "normals", "uvs"})
    assert attrs["vertex_color"].shape == (6, 4) and attrs["vertex_dir"].shape == (6, 3)
    assert_same(ours, theirs, PLY_ATTRS)


def binary_ply(order: str) -> bytes:
    """A hand-assembled binary PLY: double positions, uchar colors, texture_u/texture_v,
    ``vertex_index`` lists of uint indices with ushort counts, an element to skip."""
    bo = "<" if order == "little" else ">"
    head = (f"ply\nformat binary_{order}_endian 1.0\nelement vertex {len(POS)}\n"
            "property double x\nproperty double y\nproperty double z\n"
            "property float texture_u\nproperty float texture_v\n"
            "property uchar r\nproperty uchar g\nproperty uchar b\n"
            "element edge 1\nproperty int a\nproperty short b\n"
            "element face 4\nproperty list ushort uint vertex_index\nend_header\n").encode()
    body = b"".join(struct.pack(bo + "3d2f3B", *POS[i], *UV[i], 10 * i, 20, 255 - i)
                    for i in range(len(POS)))
    body += struct.pack(bo + "ih", 5, -2)
    for f in ([0, 1, 4], [0, 1, 2], [0, 2, 3], [3, 2, 4]):
        body += struct.pack(bo + "H3I", 3, *f)
    return head + body


@pytest.mark.parametrize("order", ["little", "big"])
def test_ply_binary_matches_mitsuba(tmp_path, order):
    path = tmp_path / f"{order}.ply"
    path.write_bytes(binary_ply(order))
    ours = read_ply(path)
    assert ours.uvs is not None and ours.normals is None
    np.testing.assert_array_equal(ours.vertex_attributes["vertex_color"][:, 0], 10 * np.arange(6))
    assert_same(ours.with_vertex_normals(), mitsuba_mesh("ply", path), ["vertex_color"])


@pytest.mark.parametrize("binary, big, dtype", [(True, False, "float32"), (True, True, "float64"),
                                                 (False, False, "float64")])
def test_write_ply_read_back_by_mitsuba(tmp_path, binary, big, dtype):
    src = tmp_path / "src.ply"
    src.write_text(ply_ascii())
    mesh = read_ply(src)
    path = tmp_path / "out.ply"
    write_ply(path, mesh, binary=binary, big_endian=big, dtype=dtype)
    again = read_ply(path)
    assert_same(again, mitsuba_mesh("ply", path), PLY_ATTRS)
    np.testing.assert_allclose(again.vertices, mesh.vertices, atol=TOL)
    for k, v in mesh.vertex_attributes.items():
        np.testing.assert_allclose(again.vertex_attributes[k], v, atol=TOL)


@pytest.mark.parametrize("binary", [False, True])
def test_ply_polygons_fan_like_mitsuba_obj(tmp_path, binary):
    """Mixed polygon sizes (rows of different lengths: the pointer-doubling path) give
    Mitsuba's OBJ fan triangulation; face attributes repeat per triangle."""
    polys = POLYS * 3
    path = tmp_path / "poly.ply"
    path.write_text(ply_ascii(polys))
    if binary:
        mesh = read_ply(path)
        lines = path.read_bytes().split(b"end_header\n")[0].decode().splitlines()
        lines[1] = "format binary_big_endian 1.0"
        types = [ln.split()[1] for ln in lines[:lines.index(f"element face {len(polys)}")]
                 if ln.startswith("property")]
        vrec = np.array([tuple(r) for r in np.loadtxt(
            path, skiprows=len(lines) + 1, max_rows=len(POS))],
            [(f"c{i}", {"float": ">f4", "double": ">f8"}[t]) for i, t in enumerate(types)])
        body = vrec.tobytes() + b"".join(struct.pack(f">B{len(p)}if", len(p), *p, k)
                                         for k, p in enumerate(polys)) + struct.pack(">2f", 7, 8)
        path.write_bytes(("\n".join(lines) + "\nend_header\n").encode() + body)
    ours = read_ply(path)
    objf = tmp_path / "poly.obj"
    objf.write_text("".join(f"v {x:g} {y:g} {z:g}\n" for x, y, z in POS)
                    + "".join("f " + " ".join(str(i + 1) for i in p) + "\n" for p in polys))
    theirs = mitsuba_mesh("obj", objf)
    np.testing.assert_allclose(ours.vertices[ours.faces], theirs["vertices"][theirs["faces"]],
                               atol=TOL)
    sizes = np.array([len(p) for p in polys])
    np.testing.assert_array_equal(ours.face_attributes["face_id"][:, 0],
                                  np.repeat(np.arange(len(polys)), sizes - 2))
    if binary:
        np.testing.assert_allclose(ours.vertices, mesh.vertices)


def test_serialized_round_trip_and_mitsuba(tmp_path):
    a = MeshData(POS, [[0, 1, 2], [0, 2, 3], [3, 2, 4], [1, 5, 2]], NRM, UV,
                 {"vertex_color": POS / 2}, name="first")     # normals not unit: normalised
    b = MeshData(POS[:5] + 1, [[0, 1, 4], [1, 2, 4]], name="second")
    for version in (3, 4):
        for double in (False, True):
            path = tmp_path / f"m{version}{double}.serialized"
            write_serialized(path, [a, b], version=version, double=double)
            for i, mesh in enumerate((a, b)):
                ours = read_serialized(path, i)
                for key in ("vertices", "faces", "normals", "uvs"):
                    x, y = getattr(ours, key), getattr(mesh, key)
                    assert (x is None) == (y is None)
                    if key == "normals" and y is not None:
                        y = y / np.linalg.norm(y, axis=1, keepdims=True)
                    if x is not None:
                        np.testing.assert_allclose(x, y, atol=TOL)
                np.testing.assert_allclose(ours.vertex_attributes.get("vertex_color", 0),
                                           mesh.vertex_attributes.get("vertex_color", 0), atol=TOL)
                assert ours.name == (mesh.name if version == 4 else f"{path.name}@{i}")
                theirs = mitsuba_mesh("serialized", path, shape_index=i)
                assert_same(ours if i == 0 else ours.with_vertex_normals(), theirs)
    assert read_serialized(path, 0, face_normals=True).normals is None


def test_read_mesh_dispatch_and_defaults(tmp_path):
    (tmp_path / "m.obj").write_text(obj_text())
    (tmp_path / "m.PLY").write_text(ply_ascii())
    assert np.array_equal(read_mesh(tmp_path / "m.obj").uvs, read_obj(tmp_path / "m.obj").uvs)
    flipped = read_mesh(tmp_path / "m.obj", flip_tex_coords=False).uvs
    np.testing.assert_allclose(flipped[:, 1], 1 - read_obj(tmp_path / "m.obj").uvs[:, 1])
    assert np.array_equal(read_mesh(tmp_path / "m.PLY").uvs, read_ply(tmp_path / "m.PLY").uvs)
    np.testing.assert_allclose(read_mesh(tmp_path / "m.PLY").uvs, UV)


def test_vertex_normals_closed_form():
    """A unit-cube corner: three right-angle faces meet; the angle weights (pi/2 each)
    give (1, 1, 1)/sqrt(3) at the corner vertex."""
    v = np.array([[0, 0, 0], [1, 0, 0], [0, 1, 0], [0, 0, 1]], float)
    f = np.array([[0, 2, 1], [0, 1, 3], [0, 3, 2]])
    np.testing.assert_allclose(vertex_normals(v, f)[0], -np.ones(3) / np.sqrt(3))
    skew = np.array([[0, 0, 0], [4, 0, 0], [0, 1, 0], [0, 0, 1]], float)
    n = vertex_normals(skew, f)[0]          # angles pi/2 each: still the diagonal
    np.testing.assert_allclose(n, -np.ones(3) / np.sqrt(3))


# ------------------------------------------------------------------------ bad input

def test_bad_obj_files_name_file_and_line(tmp_path):
    path = tmp_path / "bad.obj"
    cases = {"v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 4\n": r"bad\.obj:4: vertex index 4 is out of range",
             "v 0 0 0\nv 1 0 zero\nv 0 1 0\nf 1 2 3\n": r"bad\.obj:2: .*not numbers",
             "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 0\n": r"bad\.obj:4: vertex index 0",
             "v 0 0 0\nv 1 0 0\nv 0 1 0\nf -4 2 3\n": r"bad\.obj:4: vertex index -4",
             "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1/1 2 3\n": r"bad\.obj:4: texture coordinate index 1",
             "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2\n": r"bad\.obj:4: a face needs at least 3",
             "v 0 0 0\nv 1 0\n": r"bad\.obj:2: a vertex \(v\) needs 3 numbers",
             "v 0 0 0\nv 1 0 0\nf 1 2 3\nv 0 1 0\n": r"bad\.obj:3: vertex index 3 is out",
             "v 0 0 0\n": r"bad\.obj: the OBJ file has no faces"}
    for text, message in cases.items():
        path.write_text(text)
        with pytest.raises(ValueError, match=message):
            read_obj(path)


def test_bad_ply_and_serialized_files(tmp_path):
    good = binary_ply("little")
    path = tmp_path / "cut.ply"
    path.write_bytes(good[:-5])
    with pytest.raises(ValueError, match=r"cut\.ply: .*truncated"):
        read_ply(path)
    path.write_bytes(good + b"\0")
    with pytest.raises(ValueError, match=r"cut\.ply: trailing data"):
        read_ply(path)
    bad_index = ply_ascii().replace("\n3 0 1 4 0\n", "\n3 0 1 9 0\n")
    assert bad_index != ply_ascii()
    path.write_text(bad_index)
    with pytest.raises(ValueError, match=r"cut\.ply: PLY face indices must lie in \[0, 6\)"):
        read_ply(path, flip_tex_coords=False)
    path.write_text(obj_text())
    with pytest.raises(ValueError, match=r"cut\.ply: not a PLY file"):
        read_ply(path)
    ser = tmp_path / "cut.serialized"
    write_serialized(ser, MeshData(POS, [[0, 1, 2]]))
    data = ser.read_bytes()
    ser.write_bytes(data[:len(data) // 2])
    with pytest.raises(ValueError, match=r"cut\.serialized: .*truncated"):
        read_serialized(ser)
    ser.write_bytes(data)
    with pytest.raises(ValueError, match=r"shape_index must lie in \[0, 1\)"):
        read_serialized(ser, 1)
    ser.write_bytes(struct.pack("<HH", 0x041C, 5) + zlib.compress(b"1234"))
    with pytest.raises(ValueError, match=r"cut\.serialized: serialized file version 5"):
        read_serialized(ser)
    with pytest.raises(ValueError, match=r"path: .*mesh\.stl' has no known mesh extension"):
        read_mesh(tmp_path / "mesh.stl")
    with pytest.raises(ValueError, match=r"format must be one of obj, ply, serialized"):
        read_mesh(tmp_path / "mesh.stl", format="stl")
    with pytest.raises(ValueError, match=r"path: cannot read OBJ file"):
        read_obj(tmp_path / "missing.obj")
    with pytest.raises(TypeError, match="path must be a file path"):
        read_ply(3)
    with pytest.raises(TypeError, match="face_normals must be True or False"):
        read_obj(tmp_path / "m.obj", face_normals="yes")


def test_bad_mesh_data_and_writers(tmp_path):
    with pytest.raises(ValueError, match=r"faces must index vertices in \[0, 3\)"):
        MeshData(POS[:3], [[0, 1, 3]])
    with pytest.raises(ValueError, match=r"normals must have shape \(3, 3\)"):
        MeshData(POS[:3], [[0, 1, 2]], normals=NRM)
    with pytest.raises(TypeError, match="faces must be an integer array"):
        MeshData(POS[:3], np.array([[0.0, 1, 2]]))
    odd = MeshData(POS[:3], [[0, 1, 2]], vertex_attributes={"vertex_pair": np.ones((3, 2))})
    with pytest.raises(ValueError, match="vertex_pair.*2 channels"):
        write_ply(tmp_path / "x.ply", odd)
    with pytest.raises(ValueError, match=r"meshes\[0\]: a serialized file stores only"):
        write_serialized(tmp_path / "x.serialized", odd)
