"""Small fixture scenes for tests and benches (`tests/support/`, imported as ``support``), built on world/.

Not part of the product: the wheel leaves it out (tests/test_wheel.py) and no product module imports it
(tests/test_structure.py). Tests import it as ``from support.scenes import ...`` (pytest puts tests/ on
``sys.path``); benches and tools put ``tests/`` on ``sys.path`` first (see bench/bench_coverage.py).

Each writer puts a tiny, fully known input on disk in the layout a stage reads, so a test or a
bench can drive one stage without the stages upstream of it:

- ``mjcf``: the hand-written MJCF pieces the fixtures share (box geoms, outer walls, OBJ text).
- ``scenes``: box and mesh scenes in the converted-scene layout (MJCF of ``inst_<k>`` mesh geoms,
  scene mesh sidecar, ``scene.json``), for the observe stage; boxes come from ``world.shapes``.
- ``placement``: primitive Menagerie-style objects, a two-room table scene with its receptacle
  planes and a hand-filled relevance table, for the place stage.
- ``run_folder``: a small run folder (room, table, cabinet, three objects) for episodes and export.
- ``bundles``: the two-room ObjectNav apartment written as episode bundles (cached), for the suite
  and the navigation agents; the suite's ``fixture`` task loads it.
- ``datasets``: a Habitat scene dataset of several scene instances sharing one stage and its object templates.
"""
