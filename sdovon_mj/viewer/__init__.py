"""The browser viewer of runs (`sdovon-mj view`): a static three.js page (package data, ``static/``) and its data.

`data` builds what the page shows from a run folder (through `RunView`) and `sdovon-mj eval --out` results;
`geometry` turns MJCF models into light, coloured triangle meshes; `site` serves the files or writes them out.
"""
