"""What a run accepts: the Blender object types it reads (and those its results land on), and
the occluder shapes it may cast shadows with. Pure data (no bpy, no native core)."""

#: Object types read as meshes (anything that evaluates to one).
MESH_TYPES = frozenset({"MESH", "CURVE", "SURFACE", "META", "FONT"})
#: Object types a run reads: meshes and point clouds.
SUPPORTED_TYPES = MESH_TYPES | {"POINTCLOUD"}
#: Object types a selection may hold that show nothing in a render, or light it as lamps do:
#: left out of a run without a word. Anything else a run cannot read is named in a warning.
HELPER_TYPES = frozenset({"LIGHT", "CAMERA", "EMPTY", "ARMATURE", "LATTICE", "SPEAKER",
                          "LIGHT_PROBE", "LIGHTPROBE"})


def is_instancer(obj) -> bool:
    """An empty that instances a collection (its instances take part in a run)."""
    return (obj.type == "EMPTY" and obj.instance_type == "COLLECTION"
            and obj.instance_collection is not None)


#: Object types whose own data carries Illumap's results: the ``illumination`` attribute
#: (Transfer, the surfel object) and the preview modifiers.
RESULT_TYPES = frozenset({"MESH", "POINTCLOUD"})

#: The colour attribute that holds a run's light on the user's meshes and point clouds.
ATTRIBUTE = "illumination"
