"""Writes the groom fixtures in data/grooms/ with the tools artists use.

One small groom (48 strands of 8 points on a head-sized cap, per-point widths and colours) is
written as Cem Yuksel's `.hair` (by this script) and through Pixar's `usd-core` and Blender 5.0
(`bpy`), each in its own units and axes, so that a reader that honours a file's metadata gets
the same strands from every one of them. Run from the repository root:

    pip install usd-core==26.11 bpy==5.0.1   # bpy needs Python 3.11
    python3 data/grooms/make_grooms.py

CI never runs this: it reads the committed outputs.
"""

import math
import os
import struct

HERE = os.path.dirname(os.path.abspath(__file__))
STRANDS = 48
POINTS = 8
HEAD = (0.0, 1.6, 0.0)  # where the groom's Xform puts it, metres, Y up
RADIUS = 0.1
LENGTH = 0.15
ROOT_COLOR = (0.05, 0.03, 0.02)
TIP_COLOR = (0.40, 0.30, 0.20)


def groom():
    """The strands in the groom's own frame (metres, Y up): points, widths (diameters) and
    linear colours, one list per strand."""
    strands = []
    for i in range(STRANDS):
        y = 0.2 + 0.8 * (i + 0.5) / STRANDS
        r = math.sqrt(1.0 - y * y)
        phi = i * 2.399963229728653
        d = (r * math.cos(phi), y, r * math.sin(phi))
        side = (-math.sin(phi), 0.0, math.cos(phi))
        points, widths, colors = [], [], []
        for k in range(POINTS):
            t = k / (POINTS - 1)
            curl = 0.004 * math.sin(2.0 * k + i)
            p = [RADIUS * d[a] + LENGTH * t * d[a] + curl * side[a] for a in range(3)]
            p[1] -= 0.5 * LENGTH * t * t
            points.append(tuple(p))
            widths.append(0.0008 * (1.0 - 0.7 * t))
            colors.append(tuple(ROOT_COLOR[a] + t * (TIP_COLOR[a] - ROOT_COLOR[a]) for a in range(3)))
        strands.append((points, widths, colors))
    return strands


def at_head(p):
    return tuple(p[a] + HEAD[a] for a in range(3))


def write_hair(path, strands):
    """Cem Yuksel's .hair: the world points (the head's offset applied), per-point thickness
    (the width) and colour; segments, points, thickness and colour arrays."""
    points = [at_head(p) for s in strands for p in s[0]]
    header = struct.pack(
        "<4sIIIIff3f",
        b"HAIR",
        len(strands),
        len(points),
        0x1 | 0x2 | 0x4 | 0x10,
        POINTS - 1,
        0.0008,
        0.0,
        *ROOT_COLOR,
    )
    header += b"groom fixture: data/grooms/make_grooms.py".ljust(88, b"\0")
    assert len(header) == 128
    with open(path, "wb") as f:
        f.write(header)
        f.write(struct.pack(f"<{len(strands)}H", *[POINTS - 1] * len(strands)))
        f.write(struct.pack(f"<{3 * len(points)}f", *[c for p in points for c in p]))
        f.write(struct.pack(f"<{len(points)}f", *[w for s in strands for w in s[1]]))
        f.write(struct.pack(f"<{3 * len(points)}f", *[c for s in strands for col in s[2] for c in col]))


def write_usd(strands):
    from pxr import Gf, Sdf, Usd, UsdGeom, Vt

    def stage(path, meters, up):
        s = Usd.Stage.CreateNew(path)
        UsdGeom.SetStageMetersPerUnit(s, meters)
        UsdGeom.SetStageUpAxis(s, up)
        return s

    def curves(s, path, points, counts, cubic):
        c = UsdGeom.BasisCurves.Define(s, path)
        c.CreateCurveVertexCountsAttr(Vt.IntArray(counts))
        c.CreatePointsAttr(Vt.Vec3fArray([Gf.Vec3f(*p) for p in points]))
        c.CreateTypeAttr(UsdGeom.Tokens.cubic if cubic else UsdGeom.Tokens.linear)
        if cubic:
            c.CreateBasisAttr(UsdGeom.Tokens.catmullRom)
            c.CreateWrapAttr(UsdGeom.Tokens.pinned)
        return c

    counts = [POINTS] * len(strands)
    widths = [w for s in strands for w in s[1]]
    colors = [Gf.Vec3f(*c) for s in strands for c in s[2]]

    # Linear, metres, Y up, under an Xform that puts it at the head; vertex widths and colours.
    s = stage(os.path.join(HERE, "groom_linear.usda"), 1.0, UsdGeom.Tokens.y)
    xf = UsdGeom.Xform.Define(s, "/Character")
    xf.AddTranslateOp().Set(Gf.Vec3d(*HEAD))
    c = curves(s, "/Character/Hair", [p for st in strands for p in st[0]], counts, False)
    c.CreateWidthsAttr(Vt.FloatArray(widths)).SetMetadata("interpolation", UsdGeom.Tokens.vertex)
    pv = UsdGeom.PrimvarsAPI(c).CreatePrimvar("displayColor", Sdf.ValueTypeNames.Color3fArray, UsdGeom.Tokens.vertex)
    pv.Set(Vt.Vec3fArray(colors))
    s.SetDefaultPrim(s.GetPrimAtPath("/Character"))
    s.GetRootLayer().Save()

    # Catmull-Rom, pinned, centimetres, Z up, binary: the same strands turned into Z up
    # ((x, y, z) → (x, -z, y)) and scaled to centimetres; the head's offset on a parent Xform.
    s = stage(os.path.join(HERE, "groom_cm_zup.usdc"), 0.01, UsdGeom.Tokens.z)
    zup = lambda p: (100.0 * p[0], -100.0 * p[2], 100.0 * p[1])
    xf = UsdGeom.Xform.Define(s, "/Character")
    xf.AddTranslateOp().Set(Gf.Vec3d(*zup(HEAD)))
    c = curves(s, "/Character/Groom/Hair", [zup(p) for st in strands for p in st[0]], counts, True)
    c.CreateWidthsAttr(Vt.FloatArray([100.0 * w for w in widths])).SetMetadata(
        "interpolation", UsdGeom.Tokens.vertex
    )
    pv = UsdGeom.PrimvarsAPI(c).CreatePrimvar("displayColor", Sdf.ValueTypeNames.Color3fArray, UsdGeom.Tokens.vertex)
    pv.Set(Vt.Vec3fArray(colors))
    s.GetRootLayer().Save()

    # Widths and colours in the other interpolations: one constant width and colour for every
    # strand, then one width and colour per strand (uniform), and widths per segment end
    # (varying, which on linear curves is per vertex).
    s = stage(os.path.join(HERE, "groom_interpolations.usda"), 1.0, UsdGeom.Tokens.y)
    two = [st for st in strands[:2]]
    pts = [at_head(p) for st in two for p in st[0]]
    c = curves(s, "/Constant", pts, [POINTS] * 2, False)
    c.CreateWidthsAttr(Vt.FloatArray([0.0006])).SetMetadata("interpolation", UsdGeom.Tokens.constant)
    UsdGeom.PrimvarsAPI(c).CreatePrimvar(
        "displayColor", Sdf.ValueTypeNames.Color3fArray, UsdGeom.Tokens.constant
    ).Set(Vt.Vec3fArray([Gf.Vec3f(0.2, 0.1, 0.05)]))
    c = curves(s, "/Uniform", pts, [POINTS] * 2, False)
    c.CreateWidthsAttr(Vt.FloatArray([0.0004, 0.0007])).SetMetadata("interpolation", UsdGeom.Tokens.uniform)
    UsdGeom.PrimvarsAPI(c).CreatePrimvar(
        "displayColor", Sdf.ValueTypeNames.Color3fArray, UsdGeom.Tokens.uniform
    ).Set(Vt.Vec3fArray([Gf.Vec3f(0.3, 0.2, 0.1), Gf.Vec3f(0.6, 0.5, 0.4)]))
    c = curves(s, "/Varying", pts, [POINTS] * 2, False)
    c.CreateWidthsAttr(Vt.FloatArray([w for st in two for w in st[1]])).SetMetadata(
        "interpolation", UsdGeom.Tokens.varying
    )
    s.GetRootLayer().Save()


def write_blender(strands):
    """The groom as a Blender hair-curves object (Z up, metres: (x, y, z) → (x, -z, y)),
    exported by Blender's own USD and Alembic exporters."""
    import bpy

    for o in list(bpy.data.objects):
        bpy.data.objects.remove(o)
    hair = bpy.data.hair_curves.new("groom")
    hair.add_curves([POINTS] * len(strands))
    zup = lambda p: (p[0], -p[2], p[1])
    flat = [c for st in strands for p in st[0] for c in zup(at_head(p))]
    hair.attributes["position"].data.foreach_set("vector", flat)
    if "radius" not in hair.attributes:
        hair.attributes.new("radius", "FLOAT", "POINT")
    hair.attributes["radius"].data.foreach_set("value", [w / 2.0 for st in strands for w in st[1]])
    obj = bpy.data.objects.new("groom", hair)
    bpy.context.scene.collection.objects.link(obj)
    bpy.ops.wm.usd_export(filepath=os.path.join(HERE, "groom_blender.usdc"), export_lights=False)
    bpy.ops.wm.alembic_export(filepath=os.path.join(HERE, "groom_blender.abc"))


GUIDES = 6
MOVE = (0.0, 0.0, 0.05)  # how far the groom moves from frame 1 to frame 2, Blender's frame


def write_blender_guides(strands):
    """The groom as a character artist hands it over: two hair objects, each one group
    (`groom_group_id` 0 for even strands, 1 for odd), and a guides object (`groom_guide`), under
    a parent that moves between frames 1 and 2. Unreal's names are set both as curve attributes
    (Blender's USD exporter writes them as primvars, with per-point `groom_color`) and as object
    custom properties (all its Alembic exporter keeps of them: `.userProperties`)."""
    import bpy

    bpy.ops.wm.read_factory_settings(use_empty=True)
    zup = lambda p: (p[0], -p[2], p[1])
    rig = bpy.data.objects.new("character", None)
    bpy.context.scene.collection.objects.link(rig)
    rig.location = (0.0, 0.0, 0.0)
    rig.keyframe_insert("location", frame=1)
    rig.location = MOVE
    rig.keyframe_insert("location", frame=2)

    def hair_object(name, chosen, guide, group):
        hair = bpy.data.hair_curves.new(name)
        hair.add_curves([POINTS] * len(chosen))
        flat = [c for st in chosen for p in st[0] for c in zup(at_head(p))]
        hair.attributes["position"].data.foreach_set("vector", flat)
        if "radius" not in hair.attributes:
            hair.attributes.new("radius", "FLOAT", "POINT")
        hair.attributes["radius"].data.foreach_set("value", [w / 2.0 for st in chosen for w in st[1]])
        hair.attributes.new("groom_guide", "INT", "CURVE").data.foreach_set("value", [guide] * len(chosen))
        hair.attributes.new("groom_group_id", "INT", "CURVE").data.foreach_set("value", [group] * len(chosen))
        colors = [c for st in chosen for col in st[2] for c in (*col, 1.0)]
        hair.attributes.new("groom_color", "FLOAT_COLOR", "POINT").data.foreach_set("color", colors)
        obj = bpy.data.objects.new(name, hair)
        obj["groom_guide"] = guide
        obj["groom_group_id"] = group
        obj.parent = rig
        bpy.context.scene.collection.objects.link(obj)

    hair_object("hair_even", strands[0::2], 0, 0)
    hair_object("hair_odd", strands[1::2], 0, 1)
    # Guides: every eighth strand, a little longer, as a groomer's guides are.
    guides = [([tuple(1.05 * c for c in p) for p in st[0]], st[1], st[2]) for st in strands[:: STRANDS // GUIDES]]
    hair_object("guides", guides, 1, 0)
    scene = bpy.context.scene
    scene.frame_start, scene.frame_end = 1, 2
    bpy.ops.wm.usd_export(
        filepath=os.path.join(HERE, "groom_guides_blender.usdc"), export_lights=False, export_animation=True
    )
    bpy.ops.wm.alembic_export(
        filepath=os.path.join(HERE, "groom_guides_blender.abc"), start=1, end=2, export_custom_properties=True
    )


def write_character():
    """A skinned head for the groom's roots, as an artist would export it: a sphere of the
    groom's radius at the head's place, bound with automatic weights to a one-bone armature,
    exported by Blender's glTF exporter (+Y up, skin on; no normals or UVs, which a scalp does
    not use)."""
    import bpy

    bpy.ops.wm.read_factory_settings(use_empty=True)
    bpy.ops.mesh.primitive_uv_sphere_add(segments=24, ring_count=12, radius=RADIUS, location=(HEAD[0], -HEAD[2], HEAD[1]))
    head = bpy.context.active_object
    head.name = "head"
    bpy.ops.object.armature_add(location=(HEAD[0], -HEAD[2], HEAD[1] - 0.15))
    rig = bpy.context.active_object
    rig.name = "rig"
    bpy.ops.object.select_all(action="DESELECT")
    head.select_set(True)
    rig.select_set(True)
    bpy.context.view_layer.objects.active = rig
    bpy.ops.object.parent_set(type="ARMATURE_AUTO")
    bpy.ops.export_scene.gltf(
        filepath=os.path.join(HERE, "character_blender.glb"),
        export_format="GLB",
        export_yup=True,
        export_skins=True,
        export_animations=False,
        export_normals=False,
        export_texcoords=False,
    )


if __name__ == "__main__":
    strands = groom()
    write_hair(os.path.join(HERE, "groom.hair"), strands)
    write_usd(strands)
    write_blender(strands)
    write_blender_guides(strands)
    write_character()
