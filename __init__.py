"""Illumap: illumination maps for point models, computed with the Fast Multipole Method.

Blender loads this package as the extension; everything that touches Blender lives in ``addon``.
"""

from .addon import register, unregister

__all__ = ["register", "unregister"]
