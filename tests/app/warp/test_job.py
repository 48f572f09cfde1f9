"""`warp`'s job: the picture decoded while the cage is meshed, the picture's errors before the cage's."""

import json

import numpy as np
from support.commands import CAGE, files, private_cache, run_main, warp_argv  # noqa: F401 (fixtures)

import core
from app.commands.cli import build_parser
from app.warp.job import warp_job


def test_the_job_holds_the_cages_mesh_made_while_the_picture_was_read(files):
    args = build_parser().parse_args([str(a) for a in warp_argv(files, **{"--max-edge": 9})])
    job, _ = warp_job(args)
    assert job.image.shape == (120, 160, 4)
    expected = core.triangulate(job.curve, max_edge=9)
    np.testing.assert_array_equal(job.mesh.vertices, expected.vertices)
    np.testing.assert_array_equal(job.mesh.triangles, expected.triangles)


def test_a_bad_picture_is_named_before_a_bad_cage_and_a_cage_the_mesher_refuses_after(files, capfd):
    (files / "broken.png").write_bytes((files / "picture.png").read_bytes()[:200])
    crossed = [CAGE[0], CAGE[5], *CAGE[2:5], CAGE[1], *CAGE[6:]]  # two points swapped: it crosses itself
    (files / "crossed.json").write_text(json.dumps({"control_points": crossed}))
    argv = warp_argv(files, image=files / "broken.png", **{"--cage": files / "crossed.json"})
    code, _, err = run_main(argv, capfd)
    assert code != 0 and "broken.png" in err and "crossed.json" not in err
    code, _, err = run_main(warp_argv(files, **{"--cage": files / "crossed.json"}), capfd)
    assert code != 0 and "crossed.json" in err
    code, _, err = run_main(warp_argv(files, **{"--max-edge": 1e-9}), capfd)  # the mesher refuses it
    assert code != 0 and "cage.json: meshing" in err
    assert not (files / "out.png").exists()


def test_a_cage_covering_one_pixel_centre_at_the_images_edge_is_on_it_and_one_past_it_is_off(files, capfd):
    # A thin triangle over the centre of pixel (159, 60), the last column, and one past it.
    on = [[159.3, 59.0], [159.7, 59.0], [159.7, 62.0], [159.3, 62.0]]
    off = [[160.1, 59.0], [160.9, 59.0], [160.9, 62.0], [160.1, 62.0]]
    for points, refused in ((on, False), (off, True)):
        (files / "thin.json").write_text(json.dumps({"control_points": points}))
        thin = files / "thin.json"
        code, _, err = run_main(warp_argv(files, **{"--cage": thin, "--target": thin}), capfd)
        assert ("lies entirely outside" in err) == refused, err
