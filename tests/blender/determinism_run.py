"""One run of a saved scene, for tests/blender/light/test_determinism.py: run in a fresh process
(``python determinism_run.py SCENE.blend OUT.npz [TARGET]``, the thread count from
ILLUMAP_THREADS), it writes every receiver's value keyed by its corner identity and the
surfels' solved light."""

import os
import sys

REPO_ROOT = os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__))))
sys.path.insert(0, REPO_ROOT)

import bpy  # noqa: E402
import numpy as np  # noqa: E402


def corner_keys(mesh) -> np.ndarray:
    """Each loop's stable identity (``illumap.identities.corner_ids``)."""
    from illumap.identities import corner_ids
    nl = len(mesh.loops)
    vertex = np.empty(nl, np.int32)
    mesh.loops.foreach_get("vertex_index", vertex)
    start = np.empty(len(mesh.polygons), np.int32)
    total = np.empty(len(mesh.polygons), np.int32)
    mesh.polygons.foreach_get("loop_start", start)
    mesh.polygons.foreach_get("loop_total", total)
    following = np.arange(1, nl + 1)
    following[start + total - 1] = start
    preceding = np.arange(-1, nl - 1)
    preceding[start] = start + total - 1
    return corner_ids(vertex, vertex[following], vertex[preceding])


def solve(objects, target=None):
    """prepare → run (→ pass 2) without writing: (last job, result)."""
    from addon import pipeline
    settings = pipeline.settings_from_preset("medium", target_error=target)
    job = pipeline.prepare(bpy.context.evaluated_depsgraph_get(), objects, settings)
    result = pipeline.run(job)
    second = pipeline.next_pass(job, result)
    if second is not None:
        job, result = second, pipeline.run(second)
    return job, result


def keyed_values(result) -> dict:
    """Receiver values per object, in the order of their corners' identities."""
    out = {}
    for name, values in result.receiver_values.items():
        order = np.argsort(corner_keys(bpy.data.objects[name].data), kind="stable")
        out[name] = values[order]
    return out


def main(argv):
    import addon
    blend, out = argv[0], argv[1]
    target = float(argv[2]) if len(argv) > 2 else None
    bpy.ops.wm.open_mainfile(filepath=blend)
    if not hasattr(bpy.types.Scene, "illumap"):
        addon.register()
    objects = sorted((o for o in bpy.data.objects if o.type == "MESH"), key=lambda o: o.name)
    job, result = solve(objects, target)
    np.savez(out, surfels=result.radiosity, positions=job.positions,
             **{"corners/" + k: v for k, v in keyed_values(result).items()})


if __name__ == "__main__":
    main(sys.argv[1:])
