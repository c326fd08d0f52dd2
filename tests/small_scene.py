"""A small scene file (one emitter, 96 x 54 pixels, half a second) for the command-line
tests of drawing caches and of wedges."""

PUFF = """
[scene]
name = "puff"
duration = 0.5
fps = 10
seed = 4

[camera]
position = [0, 1, 4]
target = [0, 0.5, 0]
resolution = [96, 54]

[[system]]
name = "puff"
capacity = 400
  [[system.emitter]]
  shape = { type = "sphere", radius = 0.2 }
  rate = { type = "per_second", rate = 600 }
  speed = { uniform = [0.5, 1.5] }
  lifetime = 0.4
"""
