"""Fireworks: rockets that rise with trails and burst into coloured sparks (Reeves 1983).

Three systems, two links: every step each rocket sheds a trail particle, and each rocket's
death spawns 200 sparks with its colour and part of its velocity. Run
``python examples/fireworks.py`` for a printed summary.
"""

import motes as mo


def build_fireworks(seed: int = 7):
    """Return (rockets, trails, sparks); stepping ``rockets`` steps the other two."""
    rockets = mo.ParticleSystem(1_000, seed=seed)
    rockets.add(
        mo.Emitter(
            mo.shapes.Disc(2.0),
            mo.Burst(3, every=0.5),
            speed=mo.Uniform(14, 18),
            direction=mo.Cone((0, 1, 0), 12),
            lifetime=mo.Uniform(1.2, 1.6),
            color=mo.Gradient([(0, "#ff3030"), (0.5, "#30ff60"), (1, "#4080ff")]),
        ),
        mo.Gravity(),
    )
    trails = mo.ParticleSystem(50_000, seed=rockets.child_seed())
    trails.add(mo.Drag(1.5), mo.ColorOverLife([(0, "#ffd080"), (1, "#40200000")]))
    sparks = mo.ParticleSystem(200_000, seed=rockets.child_seed())
    sparks.add(
        mo.Gravity(),
        mo.Drag(0.6),
        mo.ColorOverLife([(0, (1, 1, 1, 1)), (1, (1, 1, 1, 0))], multiply=True),
        mo.AlphaBelow(0.02),
    )
    rockets.add(
        mo.SpawnOnEvent(
            trails,
            mo.Emitter(
                speed=mo.Uniform(0, 0.5), direction=mo.Isotropic(), lifetime=mo.Uniform(0.3, 0.6)
            ),
            on="step",
        ),
        mo.SpawnOnEvent(
            sparks,
            mo.Emitter(
                speed=mo.Uniform(4, 8),
                direction=mo.Isotropic(),
                lifetime=mo.Uniform(1.0, 2.0),
                color=(1, 1, 1, 1),
                inherit_velocity=0.3,
            ),
            on="death",
            count=200,
            inherit=("color",),
        ),
    )
    return rockets, trails, sparks


if __name__ == "__main__":
    rockets, trails, sparks = build_fireworks()
    for frame in range(1, 241):
        rockets.step(1 / 60)
        if frame % 30 == 0:
            print(
                f"t={rockets.time:4.1f} s  rockets {len(rockets):3d}  trails {len(trails):5d}  "
                f"sparks {len(sparks):6d}"
            )
