"""Reynolds (1987), "Flocks, herds and schools: a distributed behavioral model", as a
short script.

Each boid sees the others within a radius and inside its field of view, and steers by
three rules: separation (away from crowding neighbours), alignment (toward their mean
heading) and cohesion (toward their centre); a steering acceleration is "desired
velocity minus velocity" times a weight (Reynolds 1999), the sum clipped to a maximum,
the speed kept within limits. 2,000 boids start in random directions and, within a few
seconds, fly together: the polarisation |mean heading| rises from about 0 toward 1.
Prints it with the mean number of neighbours each boid sees.
"""

from motes.flock import Flock, Limits, Rule

flock = Flock.in_box(
    2_000, (-4, -4, -4), (4, 4, 4),  # [m]
    speed=2.0,  # [m/s], random directions
    seed=1,
    separation=Rule(radius=0.5, weight=4.0, fov=300),  # [m], [1/s], [degrees]
    alignment=Rule(radius=3.0, weight=10.0, fov=300),
    cohesion=Rule(radius=2.0, weight=0.5, fov=300),
    limits=Limits(min_speed=1.0, max_speed=3.0, max_acceleration=30.0, max_turn_rate=720.0),
)  # fmt: skip
for second in range(1, 6):
    for _ in range(30):
        flock.step(1 / 30)
    print(
        f"t = {second} s: polarisation {flock.polarization():.2f}, "
        f"{flock.neighbor_count.mean():.0f} neighbours"
    )
