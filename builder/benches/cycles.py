# Renders one equirectangular panorama of an OBJ scene with Blender's Cycles,
# lit like ExploreMaps' default (a sun and a uniform sky), for the render
# bench. Run: blender -b --factory-startup --python cycles.py -- \
#   OBJ OUT.png EYE_X EYE_Y EYE_Z SUN_X SUN_Y SUN_Z SUN_IRRADIANCE SKY_R SKY_G SKY_B \
#   SAMPLES WIDTH EXPOSURE METRES_PER_UNIT
# Scene coordinates are Y-up as in ExploreMaps; Blender is Z-up.
import math
import sys
import time

import bpy

args = sys.argv[sys.argv.index("--") + 1:]
obj, out = args[0], args[1]
eye = [float(v) for v in args[2:5]]
sun = [float(v) for v in args[5:8]]
sun_irradiance = float(args[8])
sky = [float(v) for v in args[9:12]]
samples, width = int(args[12]), int(args[13])
exposure, metres_per_unit = float(args[14]), float(args[15])


def z_up(v):
    """ExploreMaps (x, y, z), Y up, to Blender (x, -z, y)."""
    return (v[0], -v[2], v[1])


bpy.ops.wm.read_factory_settings(use_empty=True)
t = time.time()
bpy.ops.wm.obj_import(filepath=obj, forward_axis="NEGATIVE_Z", up_axis="Y")
# Diffuse materials, as ExploreMaps renders them.
for m in bpy.data.materials:
    if m.use_nodes:
        for n in m.node_tree.nodes:
            if n.type == "BSDF_PRINCIPLED":
                n.inputs["Specular"].default_value = 0.0
                n.inputs["Roughness"].default_value = 1.0
                n.inputs["Metallic"].default_value = 0.0
load_s = time.time() - t

scene = bpy.context.scene
scene.render.engine = "CYCLES"
scene.cycles.device = "CPU"
scene.cycles.samples = samples
scene.cycles.use_adaptive_sampling = False
scene.cycles.use_denoising = False
scene.cycles.max_bounces = 4
scene.cycles.diffuse_bounces = 4
scene.cycles.glossy_bounces = 0
scene.cycles.transmission_bounces = 0
scene.cycles.transparent_max_bounces = 4
scene.cycles.seed = 1
scene.render.threads_mode = "AUTO"
scene.render.resolution_x = width
scene.render.resolution_y = width // 2
scene.render.resolution_percentage = 100
scene.render.image_settings.file_format = "PNG"
scene.render.image_settings.color_mode = "RGB"
scene.view_settings.view_transform = "Standard"
scene.view_settings.exposure = math.log2(exposure)
# The scene's units are not metres: nothing here depends on scale but the sun's
# angular size and the sky, which are scale-free.
_ = metres_per_unit

world = bpy.data.worlds.new("sky")
world.use_nodes = True
world.node_tree.nodes["Background"].inputs["Color"].default_value = (sky[0], sky[1], sky[2], 1.0)
world.node_tree.nodes["Background"].inputs["Strength"].default_value = 1.0
scene.world = world

lamp = bpy.data.lights.new("sun", type="SUN")
lamp.energy = sun_irradiance
lamp.angle = math.radians(0.54)
sun_object = bpy.data.objects.new("sun", lamp)
scene.collection.objects.link(sun_object)
# A sun lamp shines along its local -Z: point -Z away from the sun direction.
d = z_up(sun)
sun_object.rotation_mode = "QUATERNION"
from mathutils import Vector  # noqa: E402

sun_object.rotation_quaternion = Vector(d).to_track_quat("Z", "Y")

cam_data = bpy.data.cameras.new("camera")
cam_data.type = "PANO"
try:
    cam_data.cycles.panorama_type = "EQUIRECTANGULAR"
except AttributeError:
    cam_data.panorama_type = "EQUIRECTANGULAR"
camera = bpy.data.objects.new("camera", cam_data)
camera.location = z_up(eye)
# Looking along ExploreMaps' +Z (the middle of its equirect), up along +Y.
camera.rotation_euler = (math.radians(90.0), 0.0, math.radians(180.0))
scene.collection.objects.link(camera)
scene.camera = camera

scene.render.filepath = out
t = time.time()
bpy.ops.render.render(write_still=True)
print(f"CYCLES load_s={load_s:.2f} render_s={time.time() - t:.2f} samples={samples} width={width}", flush=True)
