"""Reading a robot's files safely: references resolved (``package://``, ``model://``), reads
confined to a folder, XML parsed without entities, resource limits checked before MuJoCo, files
handed to MuJoCo as in-memory assets, meshes converted to formats MuJoCo reads.
"""

__all__: list[str] = []
