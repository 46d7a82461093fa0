"""The operator's redo panel and its preset (isoparam_addon/operation/options.py) agree:
one property per field, each property's default the preset's."""

from dataclasses import fields

import numpy as np
import pytest

from isoparam_addon.operation.options import DEFAULTS, OperatorOptions

from .conftest import bpy


def _properties():
    """The operator's properties as Blender registered them, by name."""
    rna = bpy.ops.uv.isometric_unwrap.get_rna_type()
    return {p.identifier: p for p in rna.properties if p.identifier != "rna_type"}


def test_every_property_is_a_field_of_the_preset():
    assert sorted(_properties()) == sorted(f.name for f in fields(OperatorOptions))


@pytest.mark.parametrize("name", [f.name for f in fields(OperatorOptions)])
def test_the_redo_panels_default_is_the_presets(name):
    prop, preset = _properties()[name], getattr(DEFAULTS, name)
    if prop.type == "FLOAT":  # Blender stores float properties in single precision
        assert isinstance(preset, float) and prop.default == np.float32(preset)
    else:
        assert type(prop.default) is type(preset) and prop.default == preset
