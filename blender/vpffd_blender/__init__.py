"""vpffd for Blender: a lattice that keeps the mesh's volume exact.

Select a mesh and a lattice, open the sidebar's "vpffd" tab and press
"Volume-preserving lattice". The lattice's points then show vpffd's B-spline
control points; move them (or the target empties) and the mesh follows with its
volume kept, live or baked to one shape key per frame. The add-on needs the
vpffd Python package installed into Blender's own Python (the panel says how).
"""

# Legacy add-on metadata (Blender < 4.2 and Preferences > Add-ons > Install);
# blender_manifest.toml beside this file serves the extensions system of 4.2+.
bl_info = {
    "name": "vpffd: volume-preserving lattice",
    "author": "vpffd authors",
    "version": (0, 1, 0),
    "blender": (4, 2, 0),
    "location": "View3D > Sidebar > vpffd",
    "description": "Lattice deformation with exact volume preservation, point targets and a fold check (vpffd)",
    "category": "Object",
}


def register():
    from . import ui
    ui.register()


def unregister():
    from . import ui
    ui.unregister()
