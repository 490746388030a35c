"""A small COLLADA document for the camera tests (written for the harness tests): one quad
in one colour, under nested nodes with ``<translate>``, ``<rotate>``, ``<scale>`` or
``<matrix>``."""

from __future__ import annotations

from pathlib import Path

QUAD = "0 -1 -1  0 1 -1  0 1 1  0 -1 1"  # a 2 m square in the x = 0 plane, facing -x

DOC = """<?xml version="1.0" encoding="utf-8"?>
<COLLADA xmlns="http://www.collada.org/2005/11/COLLADASchema" version="1.4.1">
  <asset><unit name="meter" meter="1"/><up_axis>Z_UP</up_axis></asset>
  <library_effects>
    <effect id="paint"><profile_COMMON><technique sid="common"><lambert>
      <diffuse><color>{color}</color></diffuse>
    </lambert></technique></profile_COMMON></effect>
  </library_effects>
  <library_materials>
    <material id="paint_material"><instance_effect url="#paint"/></material>
  </library_materials>
  <library_geometries>
    <geometry id="quad"><mesh>
      <source id="quad_positions">
        <float_array id="quad_array" count="12">{quad}</float_array>
        <technique_common><accessor source="#quad_array" count="4" stride="3">
          <param name="X" type="float"/><param name="Y" type="float"/><param name="Z" type="float"/>
        </accessor></technique_common>
      </source>
      <vertices id="quad_vertices"><input semantic="POSITION" source="#quad_positions"/></vertices>
      <triangles material="paint" count="2">
        <input semantic="VERTEX" source="#quad_vertices" offset="0"/>
        <p>0 2 1 0 3 2</p>
      </triangles>
    </mesh></geometry>
  </library_geometries>
  <library_visual_scenes>
    <visual_scene id="scene">
      <node id="outer">{outer}
        <node id="inner">{inner}
          <instance_geometry url="#quad"><bind_material><technique_common>
            <instance_material symbol="paint" target="#paint_material"/>
          </technique_common></bind_material></instance_geometry>
        </node>
      </node>
    </visual_scene>
  </library_visual_scenes>
  <scene><instance_visual_scene url="#scene"/></scene>
</COLLADA>
"""


def collada(path: Path, *, outer: str = "", inner: str = "", color: str = "0.2 0.8 0.1 1") -> Path:
    """Write the quad under ``outer`` and ``inner`` node transform elements to ``path``."""
    path.write_text(DOC.format(quad=QUAD, outer=outer, inner=inner, color=color))
    return path
