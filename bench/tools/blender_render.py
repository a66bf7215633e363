# Renders scenes from `solid sample --export-scene` with Blender Cycles, lit as
# `solid render` lights them (solid-method.md 2.6): the three area lights from the
# scene's extras["lights"] (LightRig::ToJson), the ceiling's emission and the world's
# grey 0.05. Render settings follow the reference (2.7) except the sample count and
# the denoiser: a fixed number of samples, no adaptive sampling, no denoiser.
#
#   blender -b --factory-startup --python bench/tools/blender_render.py -- \
#       --out DIR --samples 16 --threads 2 --resolution 640x480 --resolution 320x240 A.glb B.glb ...
#
# Writes DIR/<name>-<W>x<H>.png and prints one line per image:
#   blender<TAB>name<TAB>WxH<TAB>import_s<TAB>render_s<TAB>total_s
# render_s is bpy.ops.render.render alone (scene sync, BVH build and sampling); total_s
# adds the import, the light set-up and writing the PNG. Blender's start-up is in neither.
import argparse
import json
import math
import os
import sys
import time

import bpy
import numpy
from mathutils import Vector

# Debian 12's Blender 3.4 glTF importer still uses numpy.bool, which Debian's numpy 1.24
# has removed; the alias is all it needs.
if "bool" not in numpy.__dict__:
    numpy.bool = bool


def parse_args():
    argv = sys.argv[sys.argv.index("--") + 1:] if "--" in sys.argv else []
    p = argparse.ArgumentParser()
    p.add_argument("--out", required=True)
    p.add_argument("--samples", type=int, default=16)
    p.add_argument("--threads", type=int, default=2)
    p.add_argument("--resolution", action="append", default=[])
    p.add_argument("scenes", nargs="+")
    return p.parse_args(argv)


def scene_extras(path):
    # The importer drops scene-level extras, so read them from the GLB's JSON chunk.
    with open(path, "rb") as f:
        header = f.read(20)
        length = int.from_bytes(header[12:16], "little")
        return json.loads(f.read(length))["scenes"][0].get("extras", {})


def clear():
    bpy.ops.wm.read_factory_settings(use_empty=True)


def settings(scene, samples, threads):
    scene.render.engine = "CYCLES"
    c = scene.cycles
    c.device = "CPU"
    c.samples = samples
    c.use_adaptive_sampling = False
    c.use_denoising = False
    c.max_bounces = 3
    c.diffuse_bounces = 3
    c.glossy_bounces = 0
    c.transmission_bounces = 0
    c.transparent_max_bounces = 8
    c.volume_bounces = 0
    c.pixel_filter_type = "BLACKMAN_HARRIS"
    c.filter_width = 1.5
    c.seed = 0
    scene.render.threads_mode = "FIXED"
    scene.render.threads = threads
    scene.render.resolution_percentage = 100
    scene.render.image_settings.file_format = "PNG"
    scene.render.image_settings.color_mode = "RGB"
    scene.render.image_settings.color_depth = "8"
    scene.view_settings.view_transform = "Filmic"
    scene.view_settings.exposure = 0
    scene.display_settings.display_device = "sRGB"
    world = bpy.data.worlds.new("world")
    world.use_nodes = True
    world.node_tree.nodes["Background"].inputs["Color"].default_value = (0.05, 0.05, 0.05, 1)
    world.node_tree.nodes["Background"].inputs["Strength"].default_value = 1
    scene.world = world


def add_light(scene, name, light):
    data = bpy.data.lights.new(name, "AREA")
    data.shape = "SQUARE"
    data.size = light["size_m"]
    data.energy = light["power_w"]
    data.spread = math.pi
    obj = bpy.data.objects.new(name, data)
    obj.location = Vector(light["position"])
    # Area lights emit along their local -Z.
    obj.rotation_euler = (-Vector(light["direction"])).to_track_quat("Z", "Y").to_euler()
    scene.collection.objects.link(obj)


def ceiling_emission(strength):
    # The room's downward-facing top faces emit their own base colour times the rig's
    # ceiling strength (solid-method 2.6), as the reference's ceiling material does.
    room = next(o for o in bpy.data.objects if o.type == "MESH" and o.name.startswith("room"))
    mesh = room.data
    world = room.matrix_world
    top = max((world @ v.co).z for v in mesh.vertices)
    emissive = {}
    for poly in mesh.polygons:
        centre = world @ poly.center
        normal = (world.to_3x3() @ poly.normal).normalized()
        if abs(normal.z) < 0.9 or top - centre.z > 0.05:
            continue
        source = mesh.materials[poly.material_index] if mesh.materials else None
        if source is None:
            continue
        if source.name not in emissive:
            m = source.copy()
            m.name = source.name + " ceiling"
            bsdf = next(n for n in m.node_tree.nodes if n.type == "BSDF_PRINCIPLED")
            # The base colour input may be linked to a texture; emit that, too.
            base = bsdf.inputs["Base Color"]
            if base.is_linked:
                m.node_tree.links.new(base.links[0].from_socket, bsdf.inputs["Emission"])
            else:
                bsdf.inputs["Emission"].default_value = base.default_value
            bsdf.inputs["Emission Strength"].default_value = strength
            mesh.materials.append(m)
            emissive[source.name] = len(mesh.materials) - 1
        poly.material_index = emissive[source.name]


def main():
    args = parse_args()
    os.makedirs(args.out, exist_ok=True)
    for path in args.scenes:
        name = os.path.splitext(os.path.basename(path))[0]
        extras = scene_extras(path)
        for resolution in args.resolution or ["640x480"]:
            width, height = (int(v) for v in resolution.split("x"))
            start = time.perf_counter()
            clear()
            scene = bpy.context.scene
            bpy.ops.import_scene.gltf(filepath=path)
            imported = time.perf_counter()
            settings(scene, args.samples, args.threads)
            scene.render.resolution_x = width
            scene.render.resolution_y = height
            scene.camera = next(o for o in scene.objects if o.type == "CAMERA")
            rig = extras["lights"]
            for role in ("key", "fill", "back"):
                add_light(scene, role, rig[role])
            ceiling_emission(rig["ceiling_strength"])
            before = time.perf_counter()
            bpy.ops.render.render()
            rendered = time.perf_counter()
            scene.render.filepath = os.path.join(args.out, f"{name}-{width}x{height}.png")
            bpy.data.images["Render Result"].save_render(scene.render.filepath)
            done = time.perf_counter()
            print(f"blender\t{name}\t{width}x{height}\t{imported - start:.3f}\t{rendered - before:.3f}\t"
                  f"{done - start:.3f}", flush=True)


main()
