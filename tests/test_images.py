"""``load_image``: every kind of file shows as an image viewer shows it, and large photos load small;
pixel arrays of every dtype and layout (``from_array``) read by their dtype."""
import struct
import subprocess
import sys
import zlib
from pathlib import Path

import numpy as np
import pytest
import torch
from PIL import Image

from nsp.images import ImageError, from_array, from_pil, load_image, long_side

RED, BLUE, WHITE = (1.0, 0.0, 0.0), (0.0, 0.0, 1.0), (1.0, 1.0, 1.0)
PEAK_GROWTH = r"""
import re, sys
from nsp.images import load_image

def peak_kib():
    return int(re.search(r"VmHWM:\s+(\d+)", open("/proc/self/status").read())[1])

before = peak_kib()
load_image(sys.argv[1], max_side=int(sys.argv[2]))
print(peak_kib() - before)
"""  # run as `python -c PEAK_GROWTH PATH MAX_SIDE`: KiB by which loading raised the process's peak memory


def assert_colour(photo: torch.Tensor, row: int, column: int, expected: tuple[float, ...], atol: float):
    """photo (3, H, W): its pixel at (row, column) is the RGB ``expected`` within ``atol``."""
    found = [round(value, 3) for value in photo[:, row, column].tolist()]
    torch.testing.assert_close(photo[:, row, column], torch.tensor(expected), atol=atol, rtol=0,
                               msg=f"pixel ({row}, {column}) is {found}, expected {expected}")


def header_only_png(path: Path, width: int, height: int) -> Path:
    """A PNG that claims width×height 8-bit grey pixels and holds none."""
    def chunk(kind: bytes, data: bytes) -> bytes:
        return struct.pack(">I", len(data)) + kind + data + struct.pack(">I", zlib.crc32(kind + data))

    header = struct.pack(">IIBBBBB", width, height, 8, 0, 0, 0, 0)
    path.write_bytes(b"\x89PNG\r\n\x1a\n" + chunk(b"IHDR", header) + chunk(b"IEND", b""))
    return path


@pytest.mark.parametrize(
    ("mode", "value", "suffix", "expected"),
    [
        ("I;16", 32768, "png", 0.5),  # PIL's convert("RGBA") clips this to white
        ("I", 16384, "tif", 0.25),
        ("F", 0.25, "tif", 0.25),
    ],
)
def test_high_bit_depth_grey_keeps_its_brightness(tmp_path, mode, value, suffix, expected):
    path = tmp_path / f"grey.{suffix}"
    Image.new(mode, (300, 200), value).save(path)
    with Image.open(path) as saved:
        assert saved.mode == mode
    photo = load_image(str(path))
    assert photo.shape == (3, 200, 300) and photo.dtype == torch.float32
    torch.testing.assert_close(photo, torch.full_like(photo, expected), atol=1e-4, rtol=0)
    small = load_image(str(path), max_side=9)  # 33 times smaller: PIL reduces, then resamples
    assert small.shape == (3, *long_side(200, 300, 9))
    torch.testing.assert_close(small, torch.full_like(small, expected), atol=1e-3, rtol=0)


@pytest.mark.parametrize(
    ("mode", "value", "suffix", "expected"),
    [
        ("L", 128, "png", (128 / 255,) * 3),
        ("LA", (0, 128), "png", (127 / 255,) * 3),  # half-transparent black over white
        ("RGBA", (0, 0, 255, 0), "png", WHITE),
        ("1", 0, "png", (0.0,) * 3),
        ("CMYK", (0, 255, 255, 0), "jpg", RED),
        ("RGB", (0, 0, 255), "jpg", BLUE),
    ],
)
def test_every_colour_mode_loads_as_rgb_over_white(tmp_path, mode, value, suffix, expected):
    path = tmp_path / f"flat.{suffix}"
    Image.new(mode, (16, 8), value).save(path)
    photo = load_image(str(path))
    assert photo.shape == (3, 8, 16)
    assert_colour(photo, 4, 8, expected, atol=0.02)


def test_a_palette_image_shows_its_transparent_index_as_white(tmp_path):
    image = Image.new("P", (4, 2), 1)
    image.putpalette([255, 0, 0, 0, 0, 255])
    image.putpixel((0, 0), 0)
    image.save(tmp_path / "palette.png", transparency=0)
    photo = load_image(str(tmp_path / "palette.png"))
    assert_colour(photo, 0, 0, WHITE, atol=0)
    assert_colour(photo, 1, 3, BLUE, atol=0)


@pytest.mark.parametrize(("orientation", "red"), [(6, (2, 17)), (8, (27, 2))])
def test_a_jpeg_is_turned_upright_by_its_exif_orientation(tmp_path, orientation, red):
    """Stored 30 wide × 20 high with a red top-left corner; 6 turns it clockwise (the corner goes
    top-right), 8 anticlockwise (bottom-left)."""
    image = Image.new("RGB", (30, 20), "white")
    image.paste((255, 0, 0), (0, 0, 8, 8))
    exif = Image.Exif()
    exif[0x0112] = orientation
    image.save(tmp_path / "turned.jpg", exif=exif, quality=95)
    photo = load_image(str(tmp_path / "turned.jpg"))
    assert photo.shape == (3, 30, 20)
    assert_colour(photo, *red, RED, atol=0.05)
    assert_colour(photo, 29 - red[0], 19 - red[1], WHITE, atol=0.05)


def test_a_turned_jpeg_shrinks_to_max_side_with_its_aspect(tmp_path):
    exif = Image.Exif()
    exif[0x0112] = 6
    Image.new("RGB", (1203, 801), "white").save(tmp_path / "turned.jpg", exif=exif)
    photo = load_image(str(tmp_path / "turned.jpg"), max_side=100)
    assert photo.shape == (3, *long_side(1203, 801, 100)) == (3, 100, 67)


@pytest.mark.skipif(not Path("/proc/self/status").is_file(), reason="reads the peak memory Linux reports")
def test_a_large_jpeg_is_decoded_at_reduced_scale(tmp_path):
    """6000×4000: its full decode alone is 96 MB of PIL pixels (288 MB as floats); with max_side it
    must cost a few MB. Measured in a fresh process, whose peak memory (VmHWM) is its own."""
    path = tmp_path / "large.jpg"
    image = Image.new("RGB", (6000, 4000), (0, 0, 255))
    image.paste((255, 0, 0), (0, 0, 3000, 4000))
    image.save(path, quality=90)
    del image
    photo = load_image(str(path), max_side=512)
    assert photo.shape == (3, *long_side(4000, 6000, 512)) == (3, 341, 512)
    assert_colour(photo, 170, 100, RED, atol=0.05)
    assert_colour(photo, 170, 400, BLUE, atol=0.05)
    grown_kib = int(subprocess.run([sys.executable, "-c", PEAK_GROWTH, str(path), "512"], capture_output=True,
                                   text=True, check=True).stdout)
    assert grown_kib < 32 * 1024, f"peak memory grew by {grown_kib / 1024:.0f} MiB while loading"


def test_a_built_in_photo_shrinks_like_a_file():
    full = load_image("chelsea")
    small = load_image("chelsea", max_side=100)
    assert small.shape == (3, *long_side(*full.shape[-2:], 100))
    assert torch.equal(load_image("chelsea", max_side=1000), full)
    downsized = torch.nn.functional.interpolate(full[None], size=small.shape[-2:], mode="area")[0]
    assert (small - downsized).abs().mean() < 0.02


def test_a_file_that_is_not_an_image_names_itself(tmp_path):
    path = tmp_path / "notes.txt"
    path.write_text("not pixels")
    with pytest.raises(ImageError, match=rf"^image={path} is not an image this can read .*; give a PNG/JPEG path"):
        load_image(str(path))


def test_an_absurdly_large_image_names_the_limit(tmp_path):
    path = header_only_png(tmp_path / "bomb.png", 30_000, 30_000)
    with pytest.raises(ImageError, match=rf"^image={path} is 30000×30000 pixels, over the limit of 400 megapixels"):
        load_image(str(path), max_side=512)


def test_a_20000_pixel_square_passes_the_size_limit(tmp_path):
    """PIL alone refuses 400 megapixels; this header-only file gets as far as decoding."""
    path = header_only_png(tmp_path / "big.png", 20_000, 20_000)
    with pytest.raises(ImageError, match=rf"^image={path} is not an image this can read") as error:
        load_image(str(path), max_side=512)
    assert "decompression bomb" not in str(error.value)
    assert Image.MAX_IMAGE_PIXELS is not None  # PIL's guard is back for everyone else


@pytest.mark.parametrize("channels", [1, 3])
def test_ssim_is_skimages_gaussian_ssim(channels):
    from skimage.metrics import structural_similarity

    from nsp.images import ssim

    generator = torch.Generator().manual_seed(channels)
    a = torch.rand(channels, 40, 33, generator=generator, dtype=torch.float64)
    b = (a + 0.3 * torch.randn(a.shape, generator=generator, dtype=torch.float64)).clamp(0, 1)
    expected = structural_similarity(a.permute(1, 2, 0).numpy(), b.permute(1, 2, 0).numpy(), data_range=1.0,
                                     channel_axis=2, gaussian_weights=True, sigma=1.5, use_sample_covariance=False)
    assert float(ssim(a, b)) == pytest.approx(expected, abs=1e-12)
    assert float(ssim(a, a)) == pytest.approx(1.0)
    strip = ssim(a[:, :5], b[:, :5])  # narrower than the window: the window is cut to fit
    assert 0 < float(strip) < 1 and float(ssim(a[:, :1], a[:, :1])) == pytest.approx(1.0)


def test_a_painting_of_a_strip_is_scored():
    """A 12 × 600 photo is 5 px high at the 256-px scoring size, under SSIM's 11-px window."""
    from nsp.painting.outputs import similarity

    generator = torch.Generator().manual_seed(0)
    photo = torch.rand(3, 12, 600, generator=generator)
    scores = similarity(photo.flip(-1), photo)
    assert 0 < scores["ssim"] < 1 and scores["psnr"] > 0
    assert similarity(photo, photo)["ssim"] == pytest.approx(1.0)


# Pixel arrays: numpy or torch, every layout and dtype ---------------------------------------------

PHOTO = np.random.default_rng(0).integers(0, 256, (5, 7, 3), dtype=np.uint8)  # (H, W, 3): neither side a channel count
PHOTO[0, 0], PHOTO[-1, -1] = 0, 255  # the whole range
EXPECTED = torch.from_numpy(PHOTO).permute(2, 0, 1).float() / 255  # (3, 5, 7)
HWC, CHW = PHOTO, PHOTO.transpose(2, 0, 1)


@pytest.mark.parametrize("pixels", [
    HWC, torch.from_numpy(HWC), CHW, torch.from_numpy(CHW), CHW[None], torch.from_numpy(CHW)[None],  # uint8, 4 layouts
    HWC.astype(np.uint16) * 257, torch.from_numpy(HWC.astype(np.uint16) * 257),  # 16-bit, 0–65535
    HWC.astype(np.int64), HWC.astype(np.int32), HWC.astype(np.int16), torch.from_numpy(HWC).long(),  # integers: 0–255
    HWC / 255, (HWC / 255).astype(np.float32), torch.from_numpy(CHW).float() / 255,  # floats in [0, 1]
    torch.from_numpy(CHW).double() / 255, np.dstack([HWC, np.full((5, 7), 255, np.uint8)]),  # opaque RGBA
], ids=["hwc", "hwc tensor", "chw", "chw tensor", "1chw", "1chw tensor", "uint16", "uint16 tensor", "int64", "int32",
        "int16", "int64 tensor", "float64", "float32", "float32 tensor", "float64 tensor", "rgba"])
def test_every_layout_and_dtype_of_the_same_photo_reads_the_same(pixels):
    photo = from_array(pixels)
    assert photo.shape == (3, 5, 7) and photo.dtype == torch.float32
    torch.testing.assert_close(photo, EXPECTED, atol=1e-6, rtol=0)


def test_half_floats_grey_bool_and_alpha_read_by_their_values():
    torch.testing.assert_close(from_array((HWC / 255).astype(np.float16)), EXPECTED, atol=1e-3, rtol=0)
    torch.testing.assert_close(from_array(torch.from_numpy(CHW).bfloat16() / 255), EXPECTED, atol=4e-3, rtol=0)
    grey = from_array(np.full((4, 6), 32768, np.uint16))  # (H, W) 16-bit: mid grey, not white
    assert grey.shape == (3, 4, 6) and torch.allclose(grey, torch.tensor(32768 / 65535))
    mask = from_array(np.eye(4, dtype=bool))  # True white, False black
    assert mask[:, 0, 0].tolist() == [1, 1, 1] and mask[:, 0, 1].tolist() == [0, 0, 0]
    rgba = np.zeros((4, 6, 4), np.uint8)
    rgba[..., 3] = 0  # transparent black: white, as a viewer shows it
    rgba[0, 0] = (255, 0, 0, 255)  # an opaque red pixel
    photo = from_array(rgba)
    assert photo[:, 0, 0].tolist() == [1, 0, 0] and photo[:, 1, 1].tolist() == [1, 1, 1]
    assert torch.allclose(from_array(np.array([[0.5, 1.04], [-0.03, 0.0]])), torch.tensor([[0.5, 1.0], [0.0, 0.0]]))


@pytest.mark.parametrize(("pixels", "words"), [
    (HWC.astype(np.float64), "float64 values from 0 to 255; floats are read in [0, 1] (0 black, 1 white): divide 8-bit values by 255"),
    (HWC.astype(np.int32) * 257, "int32 values from 0 to 65535, outside 0–255; expected uint8 (0–255), uint16 (0–65535)"),
    (HWC.astype(np.int64) - 1, "int64 values from -1 to 254, outside 0–255"),
    (np.full((4, 4, 3), np.nan), "its float64 values include NaN or infinity"),
    (np.zeros((4, 4, 3), np.complex64), "complex64 values are not pixels"),
    (np.zeros((6, 4, 5)), "an array of shape (6, 4, 5) is not a picture; expected (H, W), (H, W, C), (C, H, W) or (1, C, H, W)"),
    (np.zeros((2, 3, 4, 4)), "an array of shape (2, 3, 4, 4) is not a picture"),
    (np.zeros((0, 4, 3)), "an array of shape (0, 4, 3) is not a picture"),
    (np.zeros(5), "an array of shape (5,) is not a picture"),
], ids=["floats of 0-255", "16-bit as int32", "negative", "nan", "complex", "5 channels", "a batch of 2", "empty", "1-d"])
def test_pixels_that_are_not_a_picture_are_refused_naming_why(pixels, words):
    with pytest.raises(ImageError) as refused:
        from_array(pixels)
    assert str(refused.value).startswith(f"image: {words}"), str(refused.value)


def test_a_pil_image_reads_as_its_file_would(tmp_path):
    image = Image.new("I;16", (6, 4), 32768)  # 16-bit grey: mid grey, not white
    torch.testing.assert_close(from_pil(image), torch.full((3, 4, 6), 32768 / 65535), atol=1e-4, rtol=0)
    transparent = Image.new("RGBA", (6, 4), (0, 0, 0, 0))
    assert from_pil(transparent).eq(1).all()  # over white
    Image.fromarray(PHOTO).save(tmp_path / "p.png")
    with Image.open(tmp_path / "p.png") as opened:
        torch.testing.assert_close(from_pil(opened), load_image(str(tmp_path / "p.png")))
