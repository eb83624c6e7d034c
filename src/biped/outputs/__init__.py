"""The files of a run: the layer above simulation and drawing that writes them.

``biped.outputs.push`` (summary.json, trajectory.csv, figures, video.mp4, replay.html of a push),
``biped.outputs.walk`` (the kinematic walk's files) and ``biped.outputs.posture`` (B's planar
runs). Imports run one way: spatial/model -> control, planar, kinematic -> sim -> analysis ->
viz -> outputs -> cli; nothing below imports this package.
"""
