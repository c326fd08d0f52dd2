"""Reeves (1983), section 2, as a short script: the five steps of a frame.

Each frame: (1) new particles are generated, N = MeanParts + Rand()·VarParts;
(2) each gets its initial attributes; (3) particles past their lifetime are
extinguished; (4) the rest are moved and transformed; (5) the image is rendered
(here: a printed summary instead).
"""

import motes as mo

fire = mo.ParticleSystem(capacity=100_000, seed=1983)
fire.add(
    # (1) generation and (2) initial attributes: a disc emitting upward in a 20° cone.
    mo.Emitter(
        mo.shapes.Disc(0.5),
        mo.PerFrame(mean=400, variance=100),
        direction=mo.Cone((0, 1, 0), 20),
        speed=mo.Uniform(2, 3),
        lifetime=mo.Uniform(0.8, 1.6),
        color="#ffe080",
        size=0.04,
    ),
    # (4) dynamics: gravity and air drag; the colour fades over each particle's life.
    mo.Gravity((0, -2.0, 0)),
    mo.Drag(0.5),
    mo.ColorOverLife([(0.0, "#ffe080"), (0.5, "#ff6020"), (1.0, "#20000000")]),
    # (3) extinction by lifetime is built in; dim particles go early too.
    mo.IntensityBelow(0.01),
)

if __name__ == "__main__":
    for frame in range(1, 121):
        fire.step(1 / 24)
        if frame % 24 == 0:
            s = fire.summary()
            top = s["bbox_max"][1]
            print(f"frame {frame:3d}: {s['count']:6d} particles, top at y = {top:.2f} m")
