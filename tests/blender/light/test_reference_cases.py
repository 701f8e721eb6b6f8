"""Illumap's default settings against Cycles on small meshes as users build them.

Six cases where a renderer that interpolates surfel values, or treats near pairs badly, goes
wrong: an emitter 1 mm under a ceiling, a box resting on a floor (contact line, hidden floor),
a room corner, a thin plate lit from one side, a floor strip against a wall, a sphere lit by a
point lamp. Each is a few hundred vertices. Cycles bakes the incident radiance at every vertex
(``bpy.ops.object.bake(type='DIFFUSE', pass_filter={'DIRECT', 'INDIRECT'},
target='VERTEX_COLORS')``, CPU, ``SAMPLES`` samples, 64 bounces, no clamping, black world), and
outgoing = albedo × incident + emission is the reference. Illumap runs with ``Settings()``
(its defaults) plus ``transfer=True, transfer_domain="POINT"`` on the same meshes, and its
``illumination`` attribute is compared over all vertices (relative RMS) and on the vertices each
case is about.

The bounds (``BOUNDS``) are what a correct renderer meets given Cycles' noise at ``SAMPLES``
samples. Measured: two bakes of these cases with different seeds differ by 0.5–1.5% relative
RMS over a case and at most 2.2% on any subset checked here; the thin plate and the sphere,
lit by a point lamp with nothing to bounce off, not at all. So 10% leaves Illumap ~8% of its
own, 5% where Cycles is exact, and "dark" means at most 2% of the case's lit level (Cycles: 0).
The bounds are not loosened to what the code does today; each test prints what it measured
(``pytest -s``). Measured on commit b2333f5 (default settings: 400 surfels/m², no visibility):

=====================  ==========================================================================
emitter under ceiling  RMS 0.060; ceiling above the emitter 0.20 of the floor's level (Cycles 0)
box on a floor         RMS 0.097; contact ring RMS 0.224 (mean ratio 0.79); hidden floor 0.035
room corner            RMS 0.035; corner edges RMS 0.075
thin plate             RMS 0.166 (lit side ratio 1.064); unlit side 0.000. The front face's
                       interior agrees to 0.8%; the error is on its outline, the vertices it
                       shares with the 5 mm rim (RMS 0.99, Illumap 1.88x): Cycles' POINT bake
                       there mixes the front's corners with the rim's
floor strip by a wall  RMS 0.075; by the wall RMS 0.052
sphere, point lamp     RMS 0.47-0.49 over runs; lit side mean ratio 0.59-0.64 (the vertex
                       facing the lamp: Cycles 0.892, analytic 0.901, Illumap 0.319). The
                       spread: bmesh's UV sphere comes in another triangle order on each build,
                       and Illumap's stratified sampling follows that order
=====================  ==========================================================================

Two open scenes under a sky came later: a box on a floor, and a sphere resting on a floor
(the bench's ``uv_sphere``, its faces in a fixed order). The sphere measured RMS 0.014,
underside RMS 0.047 once the lattice points beside its contact gathered afresh and the exact
part took the sky (three seeds against a 1024-sample bake: RMS 0.95-1.10%, underside
3.2-3.8%, where it had been 1.29-1.44% and 4.4-4.9%).

The same sphere on a floor of 0.25 m cells under a sun (black world): RMS 0.0061, underside
0.037 while its lowest receivers took the floor's light from the gather's lattice; 0.0036 and
0.018 once the sun's light is cast at the hits across the gap and the light bounced there is
gathered afresh (``illumap.gather.gaps``; 0.0039 and 0.021 with the sun's light alone).

A closed room lit through a window by the sky: mean ratio 0.975 while the lattice points'
sky light was probed (``lights.PROBE_SAMPLES``), 1.000 since the world is never probed. A box
on a floor's grid lines under a sun shining along them: its shadow's edges start at floor
vertices, read 1.41 and 0.13 of Cycles' value while a vertex's corners shared one
evaluation across the edge, 0.95 and 1.07 since.
"""

import bpy
import numpy as np
import pytest

from illumap_bpy_testing import add_lamp, link, requires_core, sky_world

from reference_helpers import (
    black_world, both, closed_box, diffuse, grid_parts, mesh, one_sided_emission, plane,
    relative_rms, report)
from bench.scenes.blender import uv_sphere

pytestmark = [requires_core, pytest.mark.slow]   # Cycles bakes as the reference

#: Error bounds per case. ``rms``: relative RMS over all vertices of the case; the others are
#: named in each test: relative RMS on a subset, or a dark level as a fraction of the lit level.
BOUNDS = {
    "emitter_under_ceiling": dict(rms=0.10, ceiling_above_emitter=0.02),
    "box_on_floor": dict(rms=0.10, contact_rms=0.10, hidden_floor=0.02),
    "room_corner": dict(rms=0.10, corner_edges_rms=0.10),
    "thin_plate": dict(rms=0.05, lit_side_rms=0.05, unlit_side=0.02),
    # Surfels whose discs reach through the wall scattered the light along it: 3.4% by the
    # wall and 2.5% on the meeting line before they were evaluated as receivers (1.3%, 0.8%).
    "floor_strip": dict(rms=0.10, by_the_wall_rms=0.025, meeting_line_rms=0.02),
    "lit_sphere": dict(rms=0.05, lit_side_rms=0.05, lit_side_ratio=0.05),
    "world_lit": dict(rms=0.05, contact_rms=0.05, hidden_floor=0.02),
    "sphere_on_floor": dict(rms=0.05, underside_rms=0.10),
    # A 256-sample bake is itself 1.25% off on this underside (against 2048 samples).
    "sphere_on_floor_sun": dict(rms=0.02, underside_rms=0.03),
    # Mean over the room's vertices: Cycles' 256-sample mean is within a few 0.1% of the light.
    "window": dict(rms=0.08, mean_ratio=0.015),
    # The vertices a shadow edge starts at: each against Cycles' value there.
    "shadow_edge_vertex": dict(ratio=0.2, rms=0.05),
}


# --- the cases -------------------------------------------------------------------------------

@pytest.fixture(autouse=True)
def world():
    black_world()


def test_emitter_just_under_a_ceiling():
    """A one-sided 0.3 m emitter (radiance 5) 1 mm under a 1 m ceiling, facing down onto a
    floor 1 m below. The ceiling above the emitter sees only its black back: dark."""
    bound = BOUNDS["emitter_under_ceiling"]
    white = diffuse("White")
    ceiling = plane("Ceiling", [(-.5, -.5, 1), (-.5, .5, 1), (.5, .5, 1), (.5, -.5, 1)], 0.05, white)
    floor = plane("Floor", [(-.5, -.5, 0), (.5, -.5, 0), (.5, .5, 0), (-.5, .5, 0)], 0.05, white)
    z = 1 - 0.001
    emitter = plane("Emitter", [(-.15, -.15, z), (-.15, .15, z), (.15, .15, z), (.15, -.15, z)], 1.0,
                    one_sided_emission("Emit", 5.0))
    got, ref, pos = both([ceiling, floor], [emitter])
    n_ceiling = len(ceiling.data.vertices)
    above = np.zeros(len(pos), bool)
    above[:n_ceiling] = (np.abs(pos[:n_ceiling, :2]) < 0.1).all(axis=1)
    lit = ref[n_ceiling:].mean()
    rms = relative_rms(got, ref)
    report("emitter under a ceiling", rms=rms, ceiling_above_ours=got[above].mean() / lit,
           ceiling_above_cycles=ref[above].mean() / lit,
           ceiling_ratio=got[:n_ceiling].mean() / ref[:n_ceiling].mean())
    assert lit > 0.05 and ref[above].mean() < bound["ceiling_above_emitter"] * lit
    assert got[above].mean() <= bound["ceiling_above_emitter"] * lit
    assert rms < bound["rms"]


def test_box_resting_on_a_floor():
    """A closed 0.5 × 0.5 × 0.4 m box on a 2 m floor, under an area lamp. The floor under the
    box is hidden (~0); the floor along the box's foot is in its contact shadow."""
    bound = BOUNDS["box_on_floor"]
    white = diffuse("White")
    floor = plane("Floor", [(-1, -1, 0), (1, -1, 0), (1, 1, 0), (-1, 1, 0)], 0.1, white)
    box = closed_box("Box", (-0.25, -0.25, 0.0), (0.25, 0.25, 0.4), 0.1, diffuse("Box", (0.6, 0.6, 0.6)))
    add_lamp("AREA", location=(0.3, -0.2, 1.5), energy=200.0, size=0.5)
    got, ref, pos = both([floor, box])
    nf = len(floor.data.vertices)
    inset = np.abs(pos[:nf, :2]).max(axis=1)
    hidden = np.flatnonzero(inset < 0.25)                     # strictly under the box
    contact = np.flatnonzero((inset > 0.25) & (inset < 0.36))  # the ring just outside its foot
    lit = ref[:nf][inset > 0.6].mean()
    rms, contact_rms = relative_rms(got, ref), relative_rms(got[contact], ref[contact])
    report("box on a floor", rms=rms, contact_rms=contact_rms,
           hidden_ours=got[hidden].mean() / lit, hidden_cycles=ref[hidden].mean() / lit,
           contact_ratio=got[contact].mean() / ref[contact].mean())
    assert len(hidden) >= 9 and len(contact) >= 16 and lit > 0.05
    assert ref[hidden].mean() <= bound["hidden_floor"] * lit
    assert got[hidden].mean() <= bound["hidden_floor"] * lit
    assert contact_rms < bound["contact_rms"]
    assert rms < bound["rms"]


def test_room_corner():
    """Floor and two walls (1 m each) meeting in a corner, a point lamp inside it."""
    bound = BOUNDS["room_corner"]
    white = diffuse("White")
    parts = [plane("Floor", [(0, 0, 0), (1, 0, 0), (1, 1, 0), (0, 1, 0)], 0.05, white),
             plane("WallX", [(0, 0, 0), (0, 1, 0), (0, 1, 1), (0, 0, 1)], 0.05, white),
             plane("WallY", [(0, 0, 0), (0, 0, 1), (1, 0, 1), (1, 0, 0)], 0.05, white)]
    add_lamp("POINT", location=(0.35, 0.35, 0.5), energy=30.0, shadow_soft_size=0.0)
    got, ref, pos = both(parts)
    # Vertices within 0.1 m of two of the planes: along the three edges of the corner.
    edges = ((pos < 0.1).sum(axis=1) >= 2)
    rms, edge_rms = relative_rms(got, ref), relative_rms(got[edges], ref[edges])
    report("room corner", rms=rms, corner_edges_rms=edge_rms,
           corner_edges_ratio=got[edges].mean() / ref[edges].mean())
    assert edges.sum() > 50
    assert edge_rms < bound["corner_edges_rms"]
    assert rms < bound["rms"]


def test_thin_plate_lit_from_one_side():
    """A 1 × 1 m plate 5 mm thick (a closed slab, as Solidify makes it), a point lamp 0.8 m in
    front of it, nothing else: the back is dark in Cycles, and must be in Illumap."""
    bound = BOUNDS["thin_plate"]
    plate = closed_box("Plate", (-0.5, -0.0025, 0.0), (0.5, 0.0025, 1.0), 0.05, diffuse("White"))
    add_lamp("POINT", location=(0.1, -0.8, 0.6), energy=50.0, shadow_soft_size=0.0)
    got, ref, pos = both([plate])
    front = pos[:, 1] < -0.002
    back = pos[:, 1] > 0.002
    lit = ref[front].mean()
    rms, front_rms = relative_rms(got, ref), relative_rms(got[front], ref[front])
    report("thin plate", rms=rms, lit_side_rms=front_rms, unlit_side_ours=got[back].mean() / lit,
           unlit_side_cycles=ref[back].mean() / lit, lit_side_ratio=got[front].mean() / lit)
    assert front.sum() > 300 and back.sum() > 300 and lit > 0.1
    assert ref[back].mean() <= bound["unlit_side"] * lit
    assert got[back].mean() <= bound["unlit_side"] * lit
    assert front_rms < bound["lit_side_rms"]
    assert rms < bound["rms"]


def test_floor_strip_against_a_wall():
    """A 2 × 0.4 m strip of floor against a 2 × 1 m wall, an area lamp above the strip."""
    bound = BOUNDS["floor_strip"]
    white = diffuse("White")
    strip = plane("Strip", [(0, 0, 0), (2, 0, 0), (2, 0.4, 0), (0, 0.4, 0)], 0.05, white)
    wall = plane("Wall", [(0, 0.4, 0), (2, 0.4, 0), (2, 0.4, 1), (0, 0.4, 1)], 0.1, white)
    add_lamp("AREA", location=(1.0, 0.15, 0.8), energy=60.0, size=0.3)
    got, ref, pos = both([strip, wall])
    by_wall = np.zeros(len(pos), bool)
    n_strip = len(strip.data.vertices)
    by_wall[:n_strip] = pos[:n_strip, 1] > 0.3
    # Where floor and wall meet, each vertex sees the other surface's light at close range.
    line = np.flatnonzero(np.abs(pos[:, 1] - 0.4) < 1e-6)
    rms, near_rms = relative_rms(got, ref), relative_rms(got[by_wall], ref[by_wall])
    line_rms = relative_rms(got[line], ref[line])
    report("floor strip by a wall", rms=rms, by_the_wall_rms=near_rms, meeting_line_rms=line_rms,
           strip_ratio=got[:n_strip].mean() / ref[:n_strip].mean(),
           wall_ratio=got[n_strip:].mean() / ref[n_strip:].mean())
    assert by_wall.sum() >= 40 and len(line) >= 60
    assert near_rms < bound["by_the_wall_rms"]
    assert line_rms < bound["meeting_line_rms"]
    assert rms < bound["rms"]


def test_sphere_lit_by_a_point_lamp():
    """A UV sphere (r 0.5 m, 32 × 16) lit by a point lamp 2 m away, nothing else: direct light
    only, which Cycles computes without noise. The lit side must match it."""
    import bmesh
    bound = BOUNDS["lit_sphere"]
    data = bpy.data.meshes.new("Sphere")
    bm = bmesh.new()
    bmesh.ops.create_uvsphere(bm, u_segments=32, v_segments=16, radius=0.5)
    bm.to_mesh(data)
    bm.free()
    data.materials.append(diffuse("White"))
    sphere = link(bpy.data.objects.new("Sphere", data))
    lamp_at = np.array([2.0, 0.0, 0.0])
    add_lamp("POINT", location=tuple(lamp_at), energy=100.0, shadow_soft_size=0.0)
    got, ref, pos = both([sphere])
    facing = (pos / 0.5) @ (lamp_at / np.linalg.norm(lamp_at))
    lit = facing > 0.5                                         # within 60° of the lamp
    rms, lit_rms = relative_rms(got, ref), relative_rms(got[lit], ref[lit])
    ratio = got[lit].mean() / ref[lit].mean()
    report("sphere and point lamp", rms=rms, lit_side_rms=lit_rms, lit_side_ratio=ratio)
    assert lit.sum() > 50 and ref[lit].mean() > 0.1
    assert abs(ratio - 1.0) < bound["lit_side_ratio"]
    assert lit_rms < bound["lit_side_rms"]
    assert rms < bound["rms"]


def test_open_scene_lit_by_the_world():
    """A box on a 2 m floor under a blue sky, no lamps: the world's light, shadowed by the box
    (the floor under it is hidden, its foot in ambient occlusion) and bounced between them."""
    bound = BOUNDS["world_lit"]
    sky_world()
    white = diffuse("White")
    floor = plane("Floor", [(-1, -1, 0), (1, -1, 0), (1, 1, 0), (-1, 1, 0)], 0.1, white)
    box = closed_box("Box", (-0.25, -0.25, 0.0), (0.25, 0.25, 0.4), 0.1, diffuse("Red", (0.7, 0.2, 0.1)))
    got, ref, pos = both([floor, box])
    nf = len(floor.data.vertices)
    inset = np.abs(pos[:nf, :2]).max(axis=1)
    hidden = np.flatnonzero(inset < 0.25)
    contact = np.flatnonzero((inset > 0.25) & (inset < 0.36))
    lit = ref[:nf][inset > 0.6].mean()
    rms, contact_rms = relative_rms(got, ref), relative_rms(got[contact], ref[contact])
    report("world-lit open scene", rms=rms, contact_rms=contact_rms,
           hidden_ours=got[hidden].mean() / lit, open_floor_ratio=got[:nf][inset > 0.6].mean() / lit,
           box_ratio=got[nf:].mean() / ref[nf:].mean())
    assert lit > 0.3 and ref[hidden].mean() <= bound["hidden_floor"] * lit
    assert got[hidden].mean() <= bound["hidden_floor"] * lit
    assert contact_rms < bound["contact_rms"]
    assert rms < bound["rms"]


def test_sphere_resting_on_a_floor_under_the_sky():
    """A UV sphere (r 0.3 m, 32 × 16) resting on a 2 m floor under a sky, no lamps. Its
    underside sees the floor beneath it, which the sphere hides from the sky: light that
    changes over centimetres, between surfels tens of centimetres apart."""
    bound = BOUNDS["sphere_on_floor"]
    sky_world()
    white = diffuse("White")
    floor = plane("Floor", [(-1, -1, 0), (1, -1, 0), (1, 1, 0), (-1, 1, 0)], 0.1, white)
    sphere = uv_sphere("Sphere", (0.0, 0.0, 0.3), 0.3, white)
    check_underside("sphere on a floor under the sky", floor, sphere, bound)


def test_room_lit_through_a_window_by_the_sky():
    """A closed 2 m room with a 0.8 m square window in one wall, under a sky, no lamps: all
    of its light comes through the window, most of it after several bounces off the walls.
    The lattice points' sky light had been probed (``lights.PROBE_SAMPLES``) and came out 0
    wherever no probe ray left through the window, so every bounce of it was short: the room
    read 2.5% dark on average (mean ratio 0.975, RMS 0.071 against 256 samples; 1.000 and
    0.067 since; Cycles' own noise is most of that RMS)."""
    bound = BOUNDS["window"]
    sky_world()
    white = diffuse("White")
    # Each quad listed so that (c1 − c0) × (c3 − c0) points into the room (asserted below).
    parts = [grid_parts(c, 0.1) for c in (
        [(0, 0, 0), (2, 0, 0), (2, 2, 0), (0, 2, 0)],            # floor
        [(0, 0, 2), (0, 2, 2), (2, 2, 2), (2, 0, 2)],            # ceiling
        [(0, 0, 0), (0, 0, 2), (2, 0, 2), (2, 0, 0)],            # y = 0
        [(0, 0, 0), (0, 2, 0), (0, 2, 2), (0, 0, 2)],            # x = 0
        [(2, 0, 0), (2, 0, 2), (2, 2, 2), (2, 2, 0)],            # x = 2
        # y = 2 around the window (x 0.6-1.4, z 0.8-1.6)
        [(0, 2, 0), (2, 2, 0), (2, 2, 0.8), (0, 2, 0.8)],
        [(0, 2, 1.6), (2, 2, 1.6), (2, 2, 2), (0, 2, 2)],
        [(0, 2, 0.8), (0.6, 2, 0.8), (0.6, 2, 1.6), (0, 2, 1.6)],
        [(1.4, 2, 0.8), (2, 2, 0.8), (2, 2, 1.6), (1.4, 2, 1.6)])]
    room = mesh("Room", parts, white)
    got, ref, pos = both([room])
    normals = np.array([p.normal[:] for p in room.data.polygons])
    centres = np.array([p.center[:] for p in room.data.polygons])
    assert (np.einsum("ij,ij->i", normals, np.array([1.0, 1.0, 1.0]) - centres) > 0).all()
    rms, ratio = relative_rms(got, ref), float(got.sum() / ref.sum())
    report("room lit through a window", rms=rms, mean_ratio=ratio)
    assert abs(ratio - 1.0) < bound["mean_ratio"]
    assert rms < bound["rms"]


def test_a_shadow_edge_through_a_floors_vertices():
    """A box standing on a floor's grid lines under a sun that shines along them: the sides of
    its shadow run along two columns of the floor's vertices, and start at the box's front
    corners, where the shadow is sharp and the vertex partly lit (its faces' corners on
    either side of the edge, one under the box). The corners of such a vertex had shared the
    first one's evaluation, a hair
    inside its face and on one side of the edge: one front vertex read 1.41 of Cycles' value,
    the other 0.13, RMS 0.0147 over the scene (0.95, 1.07 and 0.0071 since; a room lit
    through a window had them at its table's feet)."""
    bound = BOUNDS["shadow_edge_vertex"]
    white = diffuse("White")
    floor = plane("Floor", [(-1, -1, 0), (1, -1, 0), (1, 1, 0), (-1, 1, 0)], 0.1, white)
    box = closed_box("Box", (-0.2, -0.2, 0.0), (0.2, 0.2, 0.4), 0.1, white)
    sun = add_lamp("SUN", (0.0, 0.0, 5.0), name="Sun", energy=3.0, angle=np.radians(1.0))
    sun.rotation_euler = (np.radians(-45.0), 0.0, 0.0)       # light toward −y and down
    got, ref, pos = both([floor, box])
    nf = len(floor.data.vertices)
    front = np.flatnonzero((np.abs(np.abs(pos[:nf, 0]) - 0.2) < 1e-6)
                           & (np.abs(pos[:nf, 1] + 0.2) < 1e-6))
    lit = ref[:nf][pos[:nf, 1] < -0.8].mean()
    ratios = got[front].mean(axis=1) / ref[front].mean(axis=1)
    rms = relative_rms(got, ref)
    report("shadow edge through a floor's vertices", rms=rms, front_left=ratios[0],
           front_right=ratios[1], cycles_over_lit=ref[front].mean() / lit)
    assert len(front) == 2 and 0.15 < ref[front].mean() / lit < 0.85   # neither lit nor dark
    assert np.all(np.abs(ratios - 1.0) < bound["ratio"])
    assert rms < bound["rms"]


def check_underside(case, floor, sphere, bound):
    """Both renderers on a floor and the sphere resting on it: RMS over all vertices, and
    over the sphere's underside up to 15 cm (above its bottom pole, which touches the floor:
    no light reaches it in Illumap, a little in Cycles' bake at a point)."""
    got, ref, pos = both([floor, sphere])
    nf = len(floor.data.vertices)
    under = nf + np.flatnonzero((pos[nf:, 2] > 0.005) & (pos[nf:, 2] < 0.15))
    rms, under_rms = relative_rms(got, ref), relative_rms(got[under], ref[under])
    report(case, rms=rms, underside_rms=under_rms,
           underside_ratio=got[under].mean() / ref[under].mean())
    assert len(under) >= 128
    assert under_rms < bound["underside_rms"]
    assert rms < bound["rms"]


def test_sphere_resting_on_a_coarse_floor_under_a_sun():
    """The bench's UV sphere (r 0.5 m) resting on a floor of 0.25 m cells, lit by a sun 50°
    off the zenith in a black world. Its underside sees the floor across a gap of
    centimetres, where the sphere's shadow meets the sunlit floor: finer than the lattice
    the gather tabulates the floor's light on."""
    bound = BOUNDS["sphere_on_floor_sun"]
    grey = diffuse("Grey", (0.5, 0.5, 0.5))
    floor = plane("Floor", [(-2, -2, 0), (2, -2, 0), (2, 2, 0), (-2, 2, 0)], 0.25, grey)
    sphere = uv_sphere("Sphere", (0.0, 0.0, 0.5), 0.5, diffuse("Yellow", (0.75, 0.6, 0.15)))
    add_lamp("SUN", rotation=(np.radians(50.0), 0.0, np.radians(-30.0)), energy=2.0,
             angle=np.radians(1.0))
    check_underside("sphere on a coarse floor under a sun", floor, sphere, bound)
