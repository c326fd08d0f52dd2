"""Baraff & Witkin (1998), "Large steps in cloth simulation", as a short script.

A square metre of cloth, a grid of particles joined by stiff springs (their §4:
stretch, shear, bend), lying flat and held at two adjacent corners (§5: constraints
enforced by filtering), falls and swings down under gravity. It is stepped by
backward Euler linearised about the current state (§3):

    (M - h ∂f/∂v - h² ∂f/∂x) Δv = h (f0 + h ∂f/∂x v0)

solved by (filtered, preconditioned) conjugate gradients at h = 1/30 s, a step at which
explicit Euler blows up for these springs. Prints how far the cloth sags below its
pins.
"""

import motes as mo

cloth = mo.Cloth.grid(
    32,
    32,
    size=(1.0, 1.0),  # [m]
    origin=(-0.5, 1.0, 0.0),
    rotation=[[1, 0, 0], [0, 0, 1], [0, -1, 0]],  # flat: rows along +z, normal +y
    density=0.2,  # [kg/m²]
    structural=(200.0, 0.2),  # stiffness [N/m], damping [N s/m]
    shear=(50.0, 0.05),
    bending=(5.0, 0.01),
    strain_limit=0.1,  # Provot: at most 10 % stretch
)
cloth.pin(cloth.grid_index(0, [0, -1]))  # the corners of row 0
top = cloth.position[1].max()

if __name__ == "__main__":
    h = 1 / 30
    for step in range(1, 49):
        cloth.step(h)
        if step in (3, 6, 12, 24, 48):
            sag = top - cloth.position[1].min()
            iterations = cloth.last_report.iterations
            print(f"t = {step * h:.2f} s: sag {sag:.3f} m ({iterations} CG iterations)")
