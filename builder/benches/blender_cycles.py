"""Renders a scene exported by the quality bench with Blender's Cycles (the
`bpy` wheel in target/bench-py), as six 90° cube faces from one eye, at
each requested sample count and size, with or without Open Image Denoise.

Usage: python blender_cycles.py DIR (not cycles.py: that name would shadow the add-on)
DIR holds scene.json and mesh.bin written by builder/benches/quality.rs
(coordinates already Blender's: Z up). Writes DIR/cycles-{tag}-{face}.bin
(float32 linear RGB, rows top to bottom) and prints one JSON line a setting:
{"tag", "samples", "size", "denoise", "seconds"} (the six render calls, scene set-up
excluded), then {"overhead": seconds of a 1-sample 64² render of one face:
scene sync and BVH build, which every render call pays}.

Light units differ between the two renderers, so the script first measures
Cycles' own answer for a point light, a sun, an emissive surface and the
world on a one-plane scene and scales each light by it: both renderers then
get the same radiometric lights.
"""
import json
import math
import sys
import time

import bpy
import numpy as np
from mathutils import Matrix, Vector

import addon_utils  # only importable once bpy is

out = sys.argv[-1]
spec = json.load(open(f"{out}/scene.json"))


def reset():
    """An empty file with the Cycles add-on on (an empty factory file has it off)."""
    bpy.ops.wm.read_factory_settings(use_empty=True)
    addon_utils.enable("cycles", default_set=True)


def settings(size, samples, denoise):
    s = bpy.context.scene
    s.render.engine = "CYCLES"
    c = s.cycles
    c.device = "CPU"
    c.samples = samples
    c.use_adaptive_sampling = False
    c.use_denoising = denoise
    if denoise:
        c.denoiser = "OPENIMAGEDENOISE"
        c.denoising_input_passes = "RGB_ALBEDO_NORMAL"
    c.max_bounces = spec.get("bounces", 64)
    c.diffuse_bounces = spec.get("bounces", 64)
    c.glossy_bounces = 0
    c.transmission_bounces = 0
    c.volume_bounces = 0
    c.transparent_max_bounces = 64
    c.light_sampling_threshold = float(spec.get("light_threshold", 0.01))
    c.sample_clamp_direct = 0.0
    c.sample_clamp_indirect = 0.0
    c.caustics_reflective = False
    c.caustics_refractive = False
    c.seed = 1
    # Path guiding (Open PGL, CPU only): learns where light comes from, such as
    # sunlight reaching a room only by bounces, which plain paths find by chance.
    c.use_guiding = bool(spec.get("guiding", False))
    c.use_surface_guiding = c.use_guiding
    c.film_exposure = 1.0
    c.pixel_filter_type = "BOX"
    c.filter_width = 1.0
    s.render.threads_mode = "FIXED"
    s.render.threads = spec.get("threads", 2)
    s.render.resolution_x = size
    s.render.resolution_y = size
    s.render.resolution_percentage = 100
    s.render.image_settings.file_format = "OPEN_EXR"
    s.render.image_settings.color_depth = "32"
    s.render.image_settings.color_mode = "RGB"
    s.view_settings.view_transform = "Standard"
    s.view_settings.look = "None"
    s.view_settings.exposure = 0.0
    s.view_settings.gamma = 1.0


def render(path):
    """Renders the scene's camera to `path` (EXR); returns linear RGB rows top to bottom and seconds."""
    s = bpy.context.scene
    s.render.filepath = path
    t = time.perf_counter()
    bpy.ops.render.render(write_still=True)
    seconds = time.perf_counter() - t
    img = bpy.data.images.load(path)
    w, h = img.size
    px = np.array(img.pixels[:], dtype=np.float32).reshape(h, w, 4)[::-1, :, :3]
    bpy.data.images.remove(img)
    return np.ascontiguousarray(px), seconds


def camera(eye, right, up, forward, angle):
    cam = bpy.data.cameras.new("cam")
    cam.type = "PERSP"
    cam.sensor_fit = "HORIZONTAL"
    cam.angle = angle
    cam.clip_start = 1e-3
    cam.clip_end = 1e6
    obj = bpy.data.objects.new("cam", cam)
    bpy.context.scene.collection.objects.link(obj)
    rot = Matrix((right, up, [-f for f in forward])).transposed()
    obj.matrix_world = Matrix.Translation(Vector(eye)) @ rot.to_4x4()
    bpy.context.scene.camera = obj
    return obj


def diffuse_material(name, colour, emission=None):
    m = bpy.data.materials.new(name)
    m.use_nodes = True
    nodes, links = m.node_tree.nodes, m.node_tree.links
    nodes.clear()
    output = nodes.new("ShaderNodeOutputMaterial")
    bsdf = nodes.new("ShaderNodeBsdfDiffuse")
    bsdf.inputs["Color"].default_value = (*colour, 1.0)
    bsdf.inputs["Roughness"].default_value = 0.0
    shader = bsdf.outputs[0]
    if emission is not None:
        em = nodes.new("ShaderNodeEmission")
        em.inputs["Color"].default_value = (*emission, 1.0)
        em.inputs["Strength"].default_value = 1.0
        add = nodes.new("ShaderNodeAddShader")
        links.new(shader, add.inputs[0])
        links.new(em.outputs[0], add.inputs[1])
        shader = add.outputs[0]
    links.new(shader, output.inputs["Surface"])
    return m, nodes, links, bsdf, output


def world(colour_rows):
    """A world of radiance by elevation only: rows bottom (down) to top (up)."""
    w = bpy.data.worlds.new("sky")
    bpy.context.scene.world = w
    w.use_nodes = True
    nodes, links = w.node_tree.nodes, w.node_tree.links
    nodes.clear()
    bg = nodes.new("ShaderNodeBackground")
    bg.inputs["Strength"].default_value = 1.0
    outn = nodes.new("ShaderNodeOutputWorld")
    links.new(bg.outputs[0], outn.inputs["Surface"])
    if colour_rows is None:
        bg.inputs["Color"].default_value = (0, 0, 0, 1)
        return
    h, width = len(colour_rows), 8
    img = bpy.data.images.new("sky", width, h, float_buffer=True, alpha=False)
    img.colorspace_settings.name = "Non-Color"
    px = np.ones((h, width, 4), dtype=np.float32)
    px[:, :, :3] = np.array(colour_rows, dtype=np.float32)[:, None, :]
    img.pixels[:] = px.ravel()
    tex = nodes.new("ShaderNodeTexEnvironment")
    tex.image = img
    tex.interpolation = "Linear"
    links.new(tex.outputs["Color"], bg.inputs["Color"])


def plane(z, size, material):
    mesh = bpy.data.meshes.new("plane")
    h = size / 2
    mesh.from_pydata([(-h, -h, z), (h, -h, z), (h, h, z), (-h, h, z)], [], [(0, 1, 2, 3)])
    mesh.materials.append(material)
    obj = bpy.data.objects.new("plane", mesh)
    bpy.context.scene.collection.objects.link(obj)
    return obj


def calibrate():
    """Cycles' radiance for unit lights, against this project's conventions."""
    found = {}
    for kind in ["point", "sun", "emission", "world"]:
        reset()
        settings(8, 64, False)
        world(None if kind != "world" else [(1.0, 1.0, 1.0)] * 4)
        white, *_ = diffuse_material("white", (1.0, 1.0, 1.0), (1.0, 1.0, 1.0) if kind == "emission" else None)
        plane(0.0, 200.0, white)
        if kind == "point":
            light = bpy.data.lights.new("l", "POINT")
            light.energy = 1.0
            light.shadow_soft_size = 0.0
            obj = bpy.data.objects.new("l", light)
            obj.location = (0, 0, 1)
            bpy.context.scene.collection.objects.link(obj)
        if kind == "sun":
            light = bpy.data.lights.new("l", "SUN")
            light.energy = 1.0
            light.angle = 0.0
            bpy.context.scene.collection.objects.link(bpy.data.objects.new("l", light))
        # Looking straight down at the plane (for the world: straight up at the sky).
        if kind == "world":
            camera((0, 0, 2), (1, 0, 0), (0, -1, 0), (0, 0, 1), 0.01)
        else:
            camera((0, 0, 2), (1, 0, 0), (0, 1, 0), (0, 0, -1), 0.01)
        px, _ = render(f"{out}/calibrate-{kind}.exr")
        found[kind] = float(px.mean())
    # Ours: a white plane 1 below a point light of intensity 1 has radiance 1/π;
    # under a sun of irradiance 1, 1/π; emission 1 and a sky of 1 are seen as 1.
    return {
        "point": (1 / math.pi) / found["point"],
        "sun": (1 / math.pi) / found["sun"],
        "emission": 1.0 / found["emission"],
        "world": 1.0 / found["world"],
    }


scale = calibrate()
print(json.dumps({"calibration": scale}), flush=True)

reset()
mesh_bytes = open(f"{out}/mesh.bin", "rb").read()
nv, nt, has_uv = spec["vertices"], spec["triangles"], spec["uvs"]
o = 0
positions = np.frombuffer(mesh_bytes, np.float32, nv * 3, o).reshape(nv, 3)
o += nv * 12
triangles = np.frombuffer(mesh_bytes, np.uint32, nt * 3, o).reshape(nt, 3)
o += nt * 12
tri_material = np.frombuffer(mesh_bytes, np.uint32, nt, o)
o += nt * 4
uvs = np.frombuffer(mesh_bytes, np.float32, nv * 2, o).reshape(nv, 2) if has_uv else None
o += nv * 8 if has_uv else 0
normals = np.frombuffer(mesh_bytes, np.float32, nv * 3, o).reshape(nv, 3) if spec.get("normals") else None

mesh = bpy.data.meshes.new(spec["name"])
mesh.vertices.add(nv)
mesh.vertices.foreach_set("co", positions.ravel())
mesh.loops.add(nt * 3)
mesh.loops.foreach_set("vertex_index", triangles.ravel().astype(np.int32))
mesh.polygons.add(nt)
mesh.polygons.foreach_set("loop_start", np.arange(0, nt * 3, 3, dtype=np.int32))
mesh.polygons.foreach_set("loop_total", np.full(nt, 3, dtype=np.int32))
if uvs is not None:
    layer = mesh.uv_layers.new(name="uv")
    layer.data.foreach_set("uv", uvs[triangles.ravel()].ravel())
mesh.polygons.foreach_set("material_index", tri_material.astype(np.int32))
mesh.update(calc_edges=True)
mesh.validate()
# Shading as this project shades: with the scene's own vertex normals if it
# has them, else flat. (Blender 4.1+ makes faces smooth unless told, and its
# normals averaged across the creases of a welded mesh lit and darkened
# patches of the Crytek Sponza that are flat here.)
mesh.polygons.foreach_set("use_smooth", np.full(len(mesh.polygons), normals is not None, dtype=bool))
if normals is not None:
    mesh.normals_split_custom_set_from_vertices(normals)

textures = {}


def texture(t):
    """A texture given as linear float RGBA rows, bottom to top (filtered as linear values)."""
    if t["path"] not in textures:
        img = bpy.data.images.new(f"t{len(textures)}", t["width"], t["height"], alpha=True, float_buffer=True)
        img.colorspace_settings.name = "Linear Rec.709"
        img.alpha_mode = "STRAIGHT"
        img.pixels.foreach_set(np.fromfile(t["path"], dtype="<f4"))
        textures[t["path"]] = img
    return textures[t["path"]]


# "albedo_only": each surface emits its albedo, with no lights (to compare
# what the two renderers take a surface's reflectance to be).
albedo_only = spec.get("albedo_only", False)
for i, mat in enumerate(spec["materials"]):
    albedo = [min(c, 0.98) for c in mat["albedo"]]
    emission = [c * scale["emission"] for c in mat["emission"]] if any(mat["emission"]) and not albedo_only else None
    m, nodes, links, bsdf, output = diffuse_material(f"m{i}", albedo, emission)
    if mat["texture"] is not None:
        tex = nodes.new("ShaderNodeTexImage")
        tex.image = texture(mat["texture"])
        tex.interpolation = "Linear"
        tex.extension = "REPEAT"
        mul = nodes.new("ShaderNodeVectorMath")
        mul.operation = "MULTIPLY"
        # The factor as given: the cap of 0.98 is on the product, as ours has it
        # (capping the factor too made white-tinted textures 2 % darker).
        mul.inputs[1].default_value = mat["albedo"]
        links.new(tex.outputs["Color"], mul.inputs[0])
        clamp = nodes.new("ShaderNodeVectorMath")
        clamp.operation = "MINIMUM"
        clamp.inputs[1].default_value = (0.98, 0.98, 0.98)
        links.new(mul.outputs[0], clamp.inputs[0])
        links.new(clamp.outputs[0], bsdf.inputs["Color"])
    if albedo_only:
        em = nodes.new("ShaderNodeEmission")
        em.inputs["Strength"].default_value = 1.0
        em.inputs["Color"].default_value = bsdf.inputs["Color"].default_value
        if bsdf.inputs["Color"].is_linked:
            links.new(bsdf.inputs["Color"].links[0].from_socket, em.inputs["Color"])
        links.new(em.outputs[0], output.inputs["Surface"])
    if mat["texture"] is not None:
        if mat["cutoff"] is not None:
            # Holes where alpha × factor falls under the cut-off, as this project renders them.
            alpha = nodes.new("ShaderNodeMath")
            alpha.operation = "MULTIPLY"
            alpha.inputs[1].default_value = mat["alpha"]
            links.new(tex.outputs["Alpha"], alpha.inputs[0])
            solid = nodes.new("ShaderNodeMath")
            solid.operation = "GREATER_THAN"
            solid.inputs[1].default_value = mat["cutoff"] - 1e-6
            links.new(alpha.outputs[0], solid.inputs[0])
            hole = nodes.new("ShaderNodeBsdfTransparent")
            mix = nodes.new("ShaderNodeMixShader")
            links.new(solid.outputs[0], mix.inputs[0])
            links.new(hole.outputs[0], mix.inputs[1])
            surface = output.inputs["Surface"].links[0].from_socket
            links.new(surface, mix.inputs[2])
            links.new(mix.outputs[0], output.inputs["Surface"])
    mesh.materials.append(m)

scene_obj = bpy.data.objects.new(spec["name"], mesh)
bpy.context.scene.collection.objects.link(scene_obj)

def add_light(kind, rgb):
    """A light of this project's `rgb` (irradiance or intensity) in Cycles' units."""
    light = bpy.data.lights.new(kind, kind)
    peak = max(max(rgb), 1e-12)
    light.color = [c / peak for c in rgb]
    light.energy = peak * scale[kind.lower()]
    obj = bpy.data.objects.new(kind, light)
    bpy.context.scene.collection.objects.link(obj)
    return obj


for sun in [] if albedo_only else spec["suns"]:
    obj = add_light("SUN", sun["irradiance"])
    obj.data.angle = sun["angle"]
    obj.rotation_euler = Vector(sun["direction"]).to_track_quat("Z", "Y").to_euler()
for point in [] if albedo_only else spec["points"]:
    obj = add_light("POINT", point["intensity"])
    obj.data.shadow_soft_size = 0.0
    obj.location = point["position"]
world([[c * scale["world"] for c in row] for row in spec["sky_rows"]] if spec["sky_rows"] and not albedo_only else None)

cams = [camera(spec["eye"], f["right"], f["up"], f["forward"], math.pi / 2) for f in spec["faces"]]

settings(64, 1, False)
bpy.context.scene.camera = cams[0]
_, overhead = render(f"{out}/cycles-overhead.exr")
for run in spec["runs"]:
    size = run["size"]
    settings(size, run["samples"], run["denoise"])
    total = 0.0
    for f, cam in enumerate(cams):
        bpy.context.scene.camera = cam
        px, seconds = render(f"{out}/cycles-{run['tag']}-{f}.exr")
        total += seconds
        px.astype("<f4").tofile(f"{out}/cycles-{run['tag']}-{f}.bin")
    print(json.dumps({"tag": run["tag"], "samples": run["samples"], "size": size, "denoise": run["denoise"], "seconds": total}), flush=True)
print(json.dumps({"overhead": overhead}), flush=True)
