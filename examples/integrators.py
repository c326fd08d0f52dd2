"""The five integrators on one problem: a harmonic oscillator x'' = -x, energy after 10 s.

Explicit Euler gains energy every step (by exactly 1 + (ωh)²), semi-implicit Euler and
Verlet keep it bounded, velocity Verlet and RK4 are second and fourth order.
"""

import numpy as np

import motes as mo


def energy_after(integrator: str, h: float, seconds: float = 10.0) -> float:
    system = mo.ParticleSystem(1, integrator=integrator, dtype=np.float64)
    system.add(mo.CallbackForce(lambda p, v, t: -p))
    system.store.spawn(1)
    system["position"] = [[1.0, 0.0, 0.0]]
    system.run(round(seconds / h), h)
    x, v = system["position"][0, 0], system["velocity"][0, 0]
    return 0.5 * (x * x + v * v)


if __name__ == "__main__":
    print(f"{'integrator':>20}  energy after 10 s (exact 0.5)")
    for name in ("explicit_euler", "semi_implicit_euler", "verlet", "velocity_verlet", "rk4"):
        print(f"{name:>20}  {energy_after(name, 0.05):.6f}")
