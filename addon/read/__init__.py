"""Reading the Blender scene into plain arrays (main thread): meshes sampled into surfels, their materials, point clouds, lamps and the world, emissive meshes as lights, and what a run may spend."""
