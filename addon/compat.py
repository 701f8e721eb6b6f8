"""What differs between the Blender versions Illumap supports (4.2–5.0 on Python 3.11, 5.1+ on
Python 3.13), in one place: the rest of the add-on calls these helpers and never checks
``bpy.app.version`` itself.

Differences found between bpy 5.0.1 and 5.2.3 (the two tested builds):

* Geometry Nodes modifier inputs. Up to 5.1 they are ID properties on the modifier
  (``mod["Socket_1"] = value``). 5.2 gives the modifier RNA properties instead
  (``mod.properties.inputs.Socket_1.value``; Blender commit 1561c1ea4a, 5.2 Python API release
  notes) and the modifier no longer holds ID properties: ``mod[key]`` raises ``TypeError``
  ("id properties not supported for this type"). Neither write tags the object for
  re-evaluation (checked on both), so the helper does.
* Node trees of new materials and worlds. Blender 5.0 and 5.2 create them with one (and deprecate
  ``use_nodes``); 4.2 creates none until ``use_nodes`` is set (checked on bpy 4.2.23).
"""

from __future__ import annotations

from typing import Any

import bpy


def _rna_inputs(mod: bpy.types.Modifier) -> Any | None:
    """The modifier's RNA input collection (Blender 5.2+), or None where inputs are ID
    properties. Detected by the attribute rather than the version number, so a 5.1 build with or
    without the change is handled alike."""
    props = getattr(mod, "properties", None)
    return getattr(props, "inputs", None) if props is not None else None


def set_modifier_input(mod: bpy.types.Modifier, identifier: str, value: Any) -> None:
    """Set the Geometry Nodes modifier input ``identifier`` (an interface socket's
    ``identifier``, e.g. ``"Socket_1"``) to ``value`` on every supported Blender. Raises
    ``KeyError`` (up to 5.1) or ``AttributeError`` (5.2+) for an identifier it does not have."""
    inputs = _rna_inputs(mod)
    if inputs is None:
        if identifier not in mod.keys():  # an ID property write would just add a stray one
            raise KeyError(f"the modifier '{mod.name}' has no input {identifier!r}")
        mod[identifier] = value
    else:
        getattr(inputs, identifier).value = value
    # Neither write re-evaluates the modifier by itself (an ID property write, or an RNA property
    # without an update callback): tag the object so the depsgraph does.
    mod.id_data.update_tag()


def get_modifier_input(mod: bpy.types.Modifier, identifier: str) -> Any:
    """The value of the Geometry Nodes modifier input ``identifier`` on every supported
    Blender."""
    inputs = _rna_inputs(mod)
    if inputs is None:
        return mod[identifier]
    return getattr(inputs, identifier).value


def uses_nodes(idblock: bpy.types.ID) -> bool:
    """Whether a material or world renders through its node tree: always from 5.0, where
    ``use_nodes`` is deprecated; up to 4.x only when ``use_nodes`` is set."""
    if idblock.node_tree is None:
        return False
    return bpy.app.version >= (5, 0, 0) or bool(idblock.use_nodes)


def node_tree(idblock: bpy.types.ID) -> bpy.types.NodeTree:
    """The shader node tree of a material or world, made first where Blender 4.x has none."""
    if idblock.node_tree is None:
        idblock.use_nodes = True
    return idblock.node_tree
