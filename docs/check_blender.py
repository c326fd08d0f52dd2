"""Import motes exports into Blender and print what came in.

Part of the check by hand in docs/exports.md (not run by CI, which has no Blender)::

    blender --background --factory-startup --python docs/check_blender.py -- check

Imports the last file of every PLY sequence in the folder (``NAME.0001.ply``, ...)
and, where this Blender build has USD, every ``.usdc`` stage.
"""

import re
import sys
from pathlib import Path

import bpy

folder = Path(sys.argv[sys.argv.index("--") + 1])


def import_ply(path: Path) -> None:
    # Blender 3.6 and later have a built-in importer; older ones the io_mesh_ply add-on.
    if bpy.app.version >= (3, 6, 0):
        bpy.ops.wm.ply_import(filepath=str(path))
    else:
        bpy.ops.import_mesh.ply(filepath=str(path))
    mesh = bpy.context.selected_objects[0].data
    colours = getattr(mesh, "color_attributes", None) or mesh.vertex_colors
    print(
        f"{path}: {len(mesh.vertices)} vertices, {len(mesh.polygons)} faces, "
        f"colour attributes {[c.name for c in colours]}"
    )


sequences: dict[str, Path] = {}
for path in sorted(folder.glob("*.ply")):
    sequences[re.sub(r"\d+\.ply$", "", path.name)] = path  # the last frame of each
for path in sequences.values():
    import_ply(path)

for path in sorted(folder.glob("*.usdc")):
    if not bpy.app.build_options.usd:
        print(f"{path}: not imported, this Blender build has no USD support")
        continue
    bpy.ops.wm.usd_import(filepath=str(path))
    scene = bpy.context.scene
    kinds = sorted({o.type for o in bpy.context.selected_objects})
    print(
        f"{path}: {len(bpy.context.selected_objects)} objects {kinds}, "
        f"frames {scene.frame_start}..{scene.frame_end}"
    )
