"""`app.fit.growth.locally_grown` on drawn pictures: it adds what only the nearby background tells apart."""

import cv2
import numpy as np

from app.fit.colours import colour_model, log_likelihood
from app.fit.growth import GROWTH_ROUNDS, GROWTH_STEP, locally_grown

HEIGHT, WIDTH = 220, 300
#: A cylinder lit from the front: its shade across its width, 0.45 at the sides, 1 in the middle.
SHADE = 0.45 + 0.55 * np.cos(np.linspace(-np.pi / 2, np.pi / 2, 20))


def rocket_picture(nose_colour=(150, 148, 150)):
    """(bgr (H, W, 3) uint8, body (H, W) uint8, nose (H, W) bool, towers (H, W) bool): a launch pad.

    A warm white cylinder (the body) under a narrower grey one (the nose), on a sky that
    darkens from light blue at the bottom to dark blue at the top, between two grey towers
    lit as the nose is.  Gaussian noise of 3 grey levels.
    """
    rng = np.random.default_rng(3)
    depth = np.linspace(0, 1, HEIGHT)[:, None, None]  # 0 at the top, 1 at the bottom
    rgb = depth * np.array([90.0, 105, 140]) + (1 - depth) * np.array([30.0, 45, 90])
    rgb = np.broadcast_to(rgb, (HEIGHT, WIDTH, 3)).copy()
    body = np.zeros((HEIGHT, WIDTH), np.uint8)
    body[80:200, 140:160] = 1
    nose, towers = np.zeros((2, HEIGHT, WIDTH), bool)
    nose[30:80, 142:158] = True
    rgb[80:200, 140:160] = SHADE[None, :, None] * np.array([200.0, 190, 160])
    rgb[30:80, 142:158] = SHADE[None, 2:18, None] * np.array(nose_colour, float)
    for left in (20, 260):
        towers[20:210, left : left + 20] = True
        rgb[20:210, left : left + 20] = SHADE[None, :, None] * np.array([150.0, 148, 150])
    rgb += rng.normal(0, 3, rgb.shape)
    return np.ascontiguousarray(np.clip(rgb, 0, 255).astype(np.uint8)[..., ::-1]), body, nose, towers


def test_the_premise_colour_models_of_the_whole_picture_give_the_nose_to_the_background():
    # What GrabCut learns: the nose's greys are the towers', so the background explains them.
    bgr, body, nose, _ = rocket_picture()
    background = (body == 0) & ~nose
    subject_model = colour_model(bgr[body > 0], bgr[background])
    background_model = colour_model(bgr[background], bgr[body > 0])
    to_background = log_likelihood(background_model, bgr) > log_likelihood(subject_model, bgr)
    assert to_background[nose].mean() > 0.9


def test_the_nose_joins_the_body_and_neither_the_sky_nor_the_towers_do():
    bgr, body, nose, towers = rocket_picture()
    grown = locally_grown(bgr, body, (0, 0, WIDTH, HEIGHT)) > 0
    assert grown[body > 0].all() and grown[nose].mean() >= 0.98
    # Of the sky, a few pixels within a step of the outline, where the noise tips the balance.
    outside = cv2.distanceTransform((~(body > 0) & ~nose).astype(np.uint8), cv2.DIST_L2, 5)
    assert (grown & (outside > 0)).sum() <= 5 and outside[grown].max() <= GROWTH_STEP
    assert not (grown & towers).any()


def test_a_part_in_colours_the_subject_lacks_near_it_is_not_added():
    # A darker nose: its shades are not the body's, and the ring around the body's top is
    # full of them, so nothing says it belongs to the body (`locally_grown` is conservative).
    bgr, body, nose, _ = rocket_picture(nose_colour=(110, 108, 112))
    grown = locally_grown(bgr, body, (0, 0, WIDTH, HEIGHT)) > 0
    assert grown[nose].mean() <= 0.05


def test_nothing_joins_outside_the_bounds():
    bgr, body, nose, _ = rocket_picture()
    grown = locally_grown(bgr, body, (0, 60, WIDTH, HEIGHT)) > 0
    # The nose above the bounds still counts as background near the top of what may join.
    assert not grown[:60].any() and grown[60:80][nose[60:80]].mean() >= 0.8


def test_an_object_that_differs_from_its_background_everywhere_is_left_as_it_is():
    rng = np.random.default_rng(4)
    bgr = np.clip(rng.normal((40, 120, 60), 12, (HEIGHT, WIDTH, 3)), 0, 255).astype(np.uint8)
    disk = np.zeros((HEIGHT, WIDTH), np.uint8)
    cv2.circle(disk, (150, 110), 60, 1, -1)
    bgr[disk > 0] = np.clip(rng.normal((60, 60, 200), 12, (disk.sum(), 3)), 0, 255).astype(np.uint8)
    assert np.array_equal(locally_grown(bgr, disk, (0, 0, WIDTH, HEIGHT)), disk)


def test_growth_into_a_background_like_the_subject_stops_after_the_last_round():
    rng = np.random.default_rng(5)
    bgr = np.clip(rng.normal(128, 30, (HEIGHT, WIDTH, 3)), 0, 255).astype(np.uint8)
    square = np.zeros((HEIGHT, WIDTH), np.uint8)
    square[100:120, 140:160] = 1
    grown = locally_grown(bgr, square, (0, 0, WIDTH, HEIGHT))
    distance = cv2.distanceTransform(1 - square, cv2.DIST_L2, cv2.DIST_MASK_PRECISE)
    assert distance[grown > 0].max() <= GROWTH_STEP * GROWTH_ROUNDS + 1
