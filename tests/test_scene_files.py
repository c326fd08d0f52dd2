"""Scene files: loading, building the engine objects, and the validation messages."""

import numpy as np
import pytest

import motes as mo
from motes.scene import SceneError, builtin_scenes, load_scene

MINIMAL = """
[scene]
duration = 1.0
fps = 10
substeps = 2
seed = 3

[[system]]
name = "a"
capacity = 500
  [[system.emitter]]
  shape = { type = "sphere", radius = 0.2 }
  rate = { type = "per_second", rate = 300 }
  speed = { uniform = [1.0, 2.0] }
  lifetime = 0.5
"""


def test_a_minimal_scene_builds_and_steps_with_substeps():
    scene = load_scene(MINIMAL)
    assert scene.frame_count == 10
    system = scene.systems["a"]
    scene.advance()
    assert system.time == pytest.approx(0.1)  # two substeps of 0.05 s
    assert 15 <= len(system) <= 45  # ~30 births in 0.1 s
    speed = np.linalg.norm(system["velocity"], axis=1)
    assert ((speed >= 1.0) & (speed < 2.0 + 1e-6)).all()


def test_the_scene_seed_makes_runs_identical_and_can_be_overridden():
    def run(seed=None):
        scene = load_scene(MINIMAL, seed=seed)
        for _ in range(5):
            scene.advance()
        return scene.systems["a"]["position"].copy()

    np.testing.assert_array_equal(run(), run())
    assert not np.array_equal(run(), run(seed=4))


def test_every_builtin_scene_loads():
    names = builtin_scenes()
    expected = {"fire", "smoke", "fireworks", "rain", "explosion", "snow", "waterfall", "lod"}
    assert expected <= set(names)
    for name, description in names.items():
        assert description, f"{name} has no description"
        scene = load_scene(name)
        assert scene.systems or scene.bodies


def test_child_links_and_visible_colliders_are_built():
    scene = load_scene("rain")
    drops, splashes = scene.systems["drops"], scene.systems["splashes"]
    assert drops.children == [splashes]
    assert scene.roots == [drops]
    assert [o.kind for o in scene.objects] == ["ground"]


def scene_with(extra: str, system_extra: str = "") -> str:
    return f'{extra}\n[[system]]\nname = "a"\n{system_extra}\n'


@pytest.mark.parametrize(
    ("text", "path", "message"),
    [
        # unknown keys, at each level
        ("[scene]\ndurashun = 2\n" + scene_with(""), "scene.durashun", "did you mean 'duration'"),
        (scene_with("", "colour = 1"), "system[0].colour", "unknown key"),
        (
            scene_with("", '[[system.emitter]]\nrate = { type = "per_second", rate = 1, x = 2 }'),
            "system[0].emitter[0].rate.x",
            "unknown key",
        ),
        # wrong types
        ('[scene]\nduration = "long"\n' + scene_with(""), "scene.duration", "must be a number"),
        (scene_with("", "capacity = 1.5"), "system[0].capacity", "must be an integer"),
        (scene_with("[camera]\nposition = [1, 2]"), "camera.position", "array of 3 numbers"),
        (
            scene_with("", '[[system.emitter]]\ncolor = "#12345"'),
            "system[0].emitter[0].color",
            "#rrggbb",
        ),
        # out of range
        ("[scene]\nfps = 0\n" + scene_with(""), "scene.fps", "must be >= 1"),
        (scene_with("[camera]\nfov = 200"), "camera.fov", "must be < 180"),
        (
            scene_with("", '[[system.emitter]]\nshape = { type = "sphere", radius = -1 }'),
            "system[0].emitter[0].shape.radius",
            "must be > 0",
        ),
        (
            scene_with("", '[[system.force]]\ntype = "curl_noise"\nstrength = 1\nscale = 0'),
            "system[0].force[0].scale",
            "must be > 0",
        ),
        # bad choices and references
        (
            scene_with("", '[[system.force]]\ntype = "antigravity"'),
            "system[0].force[0].type",
            "must be one of 'gravity'",
        ),
        (
            scene_with("", '[[system.child]]\nsystem = "nobody"'),
            "system[0].child[0].system",
            "must be one of 'a'",
        ),
        (scene_with("", 'integrator = "leapfrog"'), "system[0].integrator", "must be one of"),
        # constructor-level checks come back with the key path
        (
            scene_with("", "[[system.emitter]]\nspeed = { uniform = [2, 1] }"),
            "system[0].emitter[0].speed",
            "high >= low",
        ),
        (scene_with("[camera]\nnear = 2\nfar = 1"), "camera.far", "far must be > near"),
        # lights
        (
            scene_with('[render]\n[[render.light]]\ntype = "spot"'),
            "render.light[0].type",
            "must be one of 'directional', 'point'",
        ),
        (
            scene_with('[render]\n[[render.light]]\ntype = "point"'),
            "render.light[0].position",
            "required",
        ),
        (
            scene_with(
                '[render]\n[[render.light]]\ntype = "point"\nposition = [0, 1, 0]\nfalloff = "yes"'
            ),
            "render.light[0].falloff",
            "true or false",
        ),
        (scene_with('[render]\nambient = "#zz0000"'), "render.ambient", "colour"),
        # structure
        ("[scene]\nduration = 1\n", "system", r"at least one \[\[system\]\] or \[\[body\]\]"),
        (scene_with("", "") + '[[system]]\nname = "a"\n', "system[1].name", "duplicate"),
    ],
)
def test_mistakes_name_the_key_path_value_and_what_is_allowed(text, path, message):
    with pytest.raises(SceneError, match=message) as info:
        load_scene(text)
    assert info.value.path == path


def test_syntax_errors_and_missing_files_are_scene_errors():
    with pytest.raises(SceneError, match="not valid TOML"):
        load_scene("[scene\nduration = 1\n")
    with pytest.raises(SceneError, match="scene file not found"):
        load_scene("does/not/exist.toml")
    with pytest.raises(SceneError, match=r"no built-in scene 'bonfire'.*built-in: "):
        load_scene("bonfire")


@pytest.mark.slow
def test_screen_scaled_rates_use_the_scene_camera():
    scene = load_scene("lod")
    near, far = scene.systems["near"], scene.systems["far"]
    for _ in range(15):
        scene.advance()
    assert isinstance(near.emitters[0].rate, mo.ScreenScaled)
    assert near.emitters[0].rate.camera is scene.camera
    assert len(near) > 10 * len(far) > 0


def test_textured_sprites_load_their_image_relative_to_the_scene_file(tmp_path):
    from motes.io.frames import save_image

    mask = np.zeros((16, 16, 3), np.uint8)
    mask[4:12, 4:12] = 255  # a bright square: opaque in the middle, clear around
    save_image(tmp_path / "square.png", mask)
    text = MINIMAL + '  [system.render]\n  texture = "square.png"\n  blend = "alpha"\n'
    path = tmp_path / "textured.toml"
    path.write_text(text)
    scene = load_scene(path)
    scene.advance()
    image = scene.render((48, 27))
    assert image.std() > 0
    style = scene._renderers[(48, 27)].styles["a"]
    assert style.texture.shape == (16, 16, 4)
    assert style.texture[8, 8, 3] == 1.0 and style.texture[0, 0, 3] == 0.0
    path.write_text(text.replace("square.png", "missing.png"))
    with pytest.raises(SceneError, match="image file not found") as info:
        load_scene(path)
    assert info.value.path == "system[0].render.texture"


def test_render_resolution_is_per_call_and_defaults_to_the_camera():
    scene = load_scene(MINIMAL.replace("[scene]", "[camera]\nresolution = [40, 30]\n\n[scene]"))
    scene.advance()
    assert scene.render((32, 18)).shape == (18, 32, 3)
    assert scene.render().shape == (30, 40, 3)  # not the size asked for last time
    assert scene.render((32, 18)).shape == (18, 32, 3)


def test_a_visible_box_collider_is_drawn_with_its_full_size_and_rotation():
    text = scene_with(
        '[[collider]]\ntype = "box"\ncenter = [0, 1, 0]\nsize = [2, 0.5, 1]\n'
        "rotation = [0, 30, 0]\nvisible = true\n"
    )
    scene = load_scene(text)
    (box,) = scene.objects
    assert box.kind == "box"
    np.testing.assert_allclose(box.params["size"], (2.0, 0.5, 1.0))
    np.testing.assert_allclose(box.params["center"], (0.0, 1.0, 0.0))
    assert scene.render((32, 18)).shape == (18, 32, 3)


def test_a_capsule_collider_is_swept_when_asked_and_drawn_as_its_surface():
    text = scene_with(
        '[[collider]]\ntype = "capsule"\na = [-0.5, 0.5, 0]\nb = [0.5, 0.5, 0]\n'
        'radius = 0.2\ndetection = "priori"\nvisible = true\n'
    )
    scene = load_scene(text)
    (capsule,) = scene.systems["a"].colliders
    assert isinstance(capsule, mo.Capsule) and capsule.swept
    assert capsule.friction_model == mo.Friction.DEPTH  # a capsule's default
    (drawn,) = scene.objects
    assert drawn.kind == "capsule" and drawn.params["radius"] == 0.2
    # Every drawn vertex lies on the capsule's surface: radius from the axis segment.
    from motes.render.geometry import Capsule

    surface = Capsule(drawn.params["a"], drawn.params["b"], 0.2).triangles(None).positions
    t = np.clip(surface[:, 0] / 1.0 + 0.5, 0.0, 1.0)
    nearest = np.stack([t - 0.5, np.full_like(t, 0.5), np.zeros_like(t)], axis=1)
    np.testing.assert_allclose(np.linalg.norm(surface - nearest, axis=1), 0.2, rtol=1e-9)
    assert scene.render((32, 18)).std() > 0


def test_an_inside_capsule_cannot_be_swept():
    text = scene_with('[[collider]]\ntype = "capsule"\ninside = true\ndetection = "priori"\n')
    with pytest.raises(SceneError, match="detection 'priori' needs a solid capsule") as error:
        load_scene(text)
    assert error.value.path == "collider[0].detection"


def test_point_lights_and_ambient_reach_the_renderer():
    from motes.render.shading import AmbientLight, PointLight
    from motes.scene.drawing import SceneRenderer

    text = scene_with(
        '[render]\nambient = ["#102030", "#000000"]\n[[render.light]]\ntype = "point"\n'
        "position = [1, 2, 3]\nintensity = 4\nfalloff = false\n"
    )
    scene = load_scene(text)
    (light,) = scene.render_settings.lights
    assert isinstance(light, PointLight) and not light.falloff
    np.testing.assert_array_equal(light.position, [1, 2, 3])
    lights = SceneRenderer(scene, (32, 18)).renderer.lights
    ambient = [x for x in lights if isinstance(x, AmbientLight)]
    assert len(ambient) == 1 and ambient[0].ground.max() == 0.0
