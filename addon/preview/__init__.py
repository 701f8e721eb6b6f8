"""Showing the light: the Object Preview on the user's own meshes and point clouds (scan splats and their shading), the Solid Preview, and the solve's surfel discs on request."""
