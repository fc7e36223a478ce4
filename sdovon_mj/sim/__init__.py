"""MuJoCo glue shared by the stages: geom groups, cameras, offscreen rendering."""

# Geom groups used across the project (MuJoCo shows groups 0-2 by default).
GROUP_SCENE = 0  # scene visual geometry (structure, furniture)
GROUP_CEILING = 1  # ceilings: hidden in top-down pictures
GROUP_OBJECT_VISUAL = 2  # object visual meshes (Menagerie class "visual")
GROUP_OBJECT_COLLISION = 3  # object CoACD hulls (Menagerie class "collision"), not rendered
GROUP_SUPPORT = 4  # support collision built for settling (receptacle prisms, floors), not rendered
GROUP_AGENT = 5  # the navigation agent's body, not rendered by its own camera
