"""Style transfer building blocks (paper §3.5): feature networks, Gram and colour losses, L*a*b*
colours, the shared recolouring and the measures of a stylized painting."""
from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
import torch
import torch.nn.functional as F
from PIL import Image
from skimage import data
from torchvision.models.vgg import cfgs, make_layers

from nsp.brushes import get_brush
from nsp.images import load_image, resize
from nsp.style import (
    Recoloring,
    StyleLoss,
    WeightsNotFound,
    gram,
    hub_cache_path,
    random_features,
    sliced_wasserstein,
    style_loss,
    vgg19_features,
)
from nsp.colors import lab_to_rgb, rgb_to_lab
from nsp.style.measures import HELD_OUT_SEED, NEAR, coherence, color_distance, luminance_ssim, texture_distance
from nsp.style.features import TappedFeatures, chosen_backbone
from nsp.style.recolor import KNOTS, STRETCH, Bounds, ColorSettings, Objective, chroma_span, gaussian_transport

pytestmark = pytest.mark.numerics  # make test runs these under other CPU kernels too

S = 48  # canvas side in pixels: small, so optimization tests stay fast on a CPU


def texture(image: np.ndarray, tint=(1.0, 1.0, 1.0)) -> torch.Tensor:
    """An skimage grayscale texture as a tinted RGB style image (1, 3, S, S)."""
    gray = torch.from_numpy(image[:192, :192].astype(np.float32) / 255)[None, None]
    return F.interpolate(gray, size=(S, S), mode="area") * torch.tensor(tint)[None, :, None, None]


@pytest.fixture(scope="module")
def astronaut() -> torch.Tensor:
    """The astronaut's face, (3, S, S)."""
    crop = data.astronaut()[30:222:4, 140:332:4].astype(np.float32) / 255
    return torch.from_numpy(crop).permute(2, 0, 1).contiguous()


@pytest.fixture(scope="module")
def fake_vgg() -> torch.nn.Sequential:
    """torchvision's VGG-19 ``features`` up to conv 7 with random weights: a stand-in for ImageNet's."""
    return make_layers(cfgs["E"])[:16].eval()


def reference_taps(features: torch.nn.Sequential, images: torch.Tensor) -> list[torch.Tensor]:
    """relu1_2, relu2_2, relu3_3 (after convs 2, 4, 7) computed directly, with ImageNet normalization."""
    mean = torch.tensor([0.485, 0.456, 0.406])[:, None, None]
    std = torch.tensor([0.229, 0.224, 0.225])[:, None, None]
    x, out = (images - mean) / std, []
    for i, layer in enumerate(features):
        x = layer(x)
        if i in (3, 8, 15):
            out.append(x.clone())
    return out


@pytest.mark.parametrize("layout", ["full model", "features only"])
def test_vgg19_loads_a_saved_state_dict(tmp_path, fake_vgg, layout):
    state = fake_vgg.state_dict()
    if layout == "full model":  # as torchvision's vgg19().state_dict() names them; classifier ignored
        state = {f"features.{k}": v for k, v in state.items()} | {"classifier.6.bias": torch.zeros(1000)}
    torch.save(state, tmp_path / "vgg.pth")
    net = vgg19_features(tmp_path / "vgg.pth")
    images = torch.rand(2, 3, 32, 32, generator=torch.Generator().manual_seed(0))
    with torch.no_grad():
        got, want = net(images), reference_taps(fake_vgg, images)
    assert [tuple(f.shape) for f in got] == [(2, 64, 32, 32), (2, 128, 16, 16), (2, 256, 8, 8)]
    for g, w in zip(got, want):
        torch.testing.assert_close(g, w)
    assert not any(p.requires_grad for p in net.parameters())


def test_vgg19_reads_the_torch_hub_cache(tmp_path, monkeypatch, fake_vgg):
    monkeypatch.setattr(torch.hub, "get_dir", lambda: str(tmp_path))
    assert hub_cache_path() == tmp_path / "checkpoints" / "vgg19-dcbb9e9d.pth"
    hub_cache_path().parent.mkdir()
    torch.save(fake_vgg.state_dict(), hub_cache_path())
    style = torch.rand(1, 3, 32, 32, generator=torch.Generator().manual_seed(0))
    loss = StyleLoss(style, backbone="vgg19")
    assert loss(style).item() == pytest.approx(0.0, abs=1e-6)
    assert loss(F.avg_pool2d(style, 5, 1, 2)).item() > 0.01  # blurred: another texture


def test_missing_vgg19_weights_give_one_clear_error(tmp_path, monkeypatch):
    monkeypatch.setattr(torch.hub, "get_dir", lambda: str(tmp_path / "empty"))
    with pytest.raises(WeightsNotFound) as err:
        StyleLoss(torch.rand(1, 3, 16, 16), backbone="vgg19")
    message = str(err.value)
    assert "\n" not in message
    for part in (str(hub_cache_path()), "IMAGENET1K_V1", "style.weights=PATH", "style.backbone=random"):
        assert part in message
    with pytest.raises(FileNotFoundError, match="nowhere.pth"):
        vgg19_features(tmp_path / "nowhere.pth")


def test_auto_is_vgg19_where_its_weights_are_else_random(tmp_path, monkeypatch, fake_vgg):
    from torchvision.models import VGG19_Weights

    assert hub_cache_path().name == Path(VGG19_Weights.IMAGENET1K_V1.url).name  # found without importing torchvision
    monkeypatch.setattr(torch.hub, "get_dir", lambda: str(tmp_path))
    assert chosen_backbone("auto") == "random" and chosen_backbone("vgg19") == "vgg19"
    hub_cache_path().parent.mkdir()
    torch.save(fake_vgg.state_dict(), hub_cache_path())
    assert chosen_backbone("auto") == "vgg19" and chosen_backbone("auto", tmp_path / "nowhere.pth") == "random"
    assert isinstance(StyleLoss(torch.rand(1, 3, 16, 16)).features, TappedFeatures)  # the default: auto


def test_unknown_backbone_lists_the_choices():
    with pytest.raises(ValueError, match="auto, vgg19, random"):
        StyleLoss(torch.rand(1, 3, 16, 16), backbone="resnet")


def test_random_backbone_is_deterministic_from_the_seed():
    images = torch.rand(1, 3, 32, 32, generator=torch.Generator().manual_seed(0))
    a, b, c = random_features(7)(images), random_features(7)(images), random_features(8)(images)
    assert all(torch.equal(x, y) for x, y in zip(a, b))
    assert not any(torch.equal(x, z) for x, z in zip(a, c))
    assert [tuple(f.shape[2:]) for f in a] == [(32, 32), (16, 16), (8, 8)]
    assert list(random_features(7).parameters()) == []  # frozen: filters are buffers

    canvas = torch.rand(1, 3, 32, 32, generator=torch.Generator().manual_seed(1))
    loss = lambda seed: StyleLoss(images, "random", seed=seed)(canvas)  # noqa: E731
    assert torch.equal(loss(3), loss(3))
    assert not torch.equal(loss(3), loss(4))


def test_style_loss_is_zero_for_the_same_image_and_positive_otherwise(astronaut):
    net = random_features(0)
    brick = texture(data.brick())
    feats_a, feats_b = net(astronaut[None]), net(brick)
    g = gram(feats_a[0])
    assert g.shape == (1, 128, 128) and torch.allclose(g, g.transpose(1, 2))
    assert style_loss(feats_a, feats_a).item() == 0.0
    assert 0.1 < style_loss(feats_a, feats_b).item() <= 1.0
    big_brick = net(F.interpolate(brick, scale_factor=2))  # Grams compare images of any size
    assert style_loss(feats_b, big_brick).item() < style_loss(feats_a, big_brick).item()


def test_sliced_wasserstein_compares_colour_distributions(astronaut):
    g = torch.Generator().manual_seed(0)
    shuffled = astronaut.flatten(1)[:, torch.randperm(S * S, generator=g)].reshape(1, 3, S, S)
    assert sliced_wasserstein(astronaut[None], shuffled, generator=g).item() < 1e-6
    canvas = astronaut[None].clone().requires_grad_(True)
    gray = texture(data.grass(), tint=(1.0, 1.0, 1.0))[..., :20, :30]  # another size: quantile-matched
    distance = sliced_wasserstein(canvas, gray, generator=g)
    distance.backward()
    assert distance.item() > 0.05 and canvas.grad.abs().sum() > 0


def test_a_style_image_is_read_by_the_one_loader_and_named_in_its_errors(tmp_path):
    Image.fromarray(np.zeros((20, 40, 3), dtype=np.uint8)).save(tmp_path / "style.png")
    image = resize(load_image(str(tmp_path / "style.png"), max_side=32, key="style.image"), 32)
    assert image.shape == (3, 16, 32) and image.dtype == torch.float32
    (tmp_path / "notes.txt").write_text("not an image")
    with pytest.raises(ValueError, match=r"^style\.image=.*notes.txt") as err:
        load_image(str(tmp_path / "notes.txt"), key="style.image")
    assert "\n" not in str(err.value)


def test_lab_matches_reference_values_and_inverts():
    rgb = torch.tensor([[1.0, 1.0, 1.0], [0.0, 0.0, 0.0], [1.0, 0.0, 0.0], [0.0, 0.0, 1.0]])
    want = torch.tensor([[1.0, 0.0, 0.0], [0.0, 0.0, 0.0], [0.5324, 0.8009, 0.6720], [0.3230, 0.7919, -1.0786]])
    torch.testing.assert_close(rgb_to_lab(rgb), want, atol=2e-4, rtol=0)  # CIE L*a*b* / 100, D65
    images = torch.rand(2, 3, 8, 8, generator=torch.Generator().manual_seed(0))
    torch.testing.assert_close(lab_to_rgb(rgb_to_lab(images, dim=1), dim=1), images, atol=1e-5, rtol=0)


def test_gaussian_transport_carries_one_covariance_onto_the_other():
    g = torch.Generator().manual_seed(0)
    a, b = torch.randn(2, 2, generator=g, dtype=torch.float64), torch.randn(2, 2, generator=g, dtype=torch.float64)
    source, target = a @ a.T + 0.1 * torch.eye(2, dtype=torch.float64), b @ b.T
    matrix = gaussian_transport(source, target)
    torch.testing.assert_close(matrix, matrix.T)
    torch.testing.assert_close(matrix @ source @ matrix, target)


def test_the_start_carries_chroma_to_the_style_and_keeps_the_lightness(astronaut):
    style = texture(data.brick(), tint=(0.9, 0.6, 0.3))[0]
    lab_s = rgb_to_lab(style.flatten(1), dim=0)
    start = Recoloring.fit(astronaut, style)
    torch.testing.assert_close(start.mean_out, lab_s[1:].mean(1), atol=1e-5, rtol=0)
    assert torch.linalg.eigvalsh(start.matrix).max() <= STRETCH + 1e-6 and start.hue.abs().max() == 0
    torch.testing.assert_close(start.lightness, torch.linspace(0, 1, KNOTS + 1))  # f: the identity
    out = rgb_to_lab(start(astronaut, dim=0), dim=0)
    change = (out[0] - rgb_to_lab(astronaut, dim=0)[0]).abs()
    assert change.median() < 1e-5 and change.max() < 0.05  # but where sRGB lacks the new chroma, clamping moves it
    recoloured = start.lab(rgb_to_lab(astronaut.flatten(1), dim=0).T)  # before clamping to sRGB
    torch.testing.assert_close(recoloured[:, 1:].mean(0), lab_s[1:].mean(1), atol=1e-4, rtol=0)  # the style's mean hue


def test_the_start_toward_its_own_colours_changes_nothing(astronaut):
    start = Recoloring.fit(astronaut, astronaut)
    torch.testing.assert_close(start(astronaut, dim=0), astronaut, atol=1e-2, rtol=0)  # up to EPS


def test_the_start_keeps_alike_colours_alike(astronaut):
    # a drab painting toward a vivid style: the map stretches chroma differences at most STRETCH×
    drab = 0.5 + 0.1 * (astronaut - 0.5)
    vivid = (texture(data.brick(), tint=(1.0, 0.2, 0.1)) + texture(data.grass(), tint=(0.0, 0.8, 0.0)))[0]
    start = Recoloring.fit(drab, vivid.clamp(0, 1))
    assert torch.linalg.matrix_norm(start.matrix, ord=2) <= STRETCH + 1e-6
    assert coherence(drab, start(drab, dim=0)) <= 0.05
    assert color_distance(start(drab, dim=0), vivid) < 0.5 * color_distance(drab, vivid)


@pytest.fixture(scope="module")
def grey_to_colour(astronaut):
    """A grey photo (the astronaut's lightness), a style whose hue follows its tones (dark blue,
    light orange), the start and the map refined under a floor and a bound."""
    grey = astronaut.mean(0, keepdim=True).expand(3, -1, -1).contiguous()
    tones = texture(data.gravel())[0, 0]
    style = torch.stack([tones, 0.4 + 0.2 * tones, 1 - tones]) * torch.stack([tones, tones.sqrt(), 0.5 * tones])
    style = (style / style.amax(dim=(1, 2), keepdim=True)).clamp(0, 1)
    return (grey, style, *refined(grey, style))


def refined(grey: torch.Tensor, style: torch.Tensor) -> tuple[Recoloring, float, Recoloring]:
    """The start of ``grey`` toward ``style``, the SSIM floor of β 0.5 (0.9 × the plain painting's)
    and the map refined under it and a coherence bound of 0.045."""
    start, settings = Recoloring.fit(grey, style), ColorSettings(coherence=0.045)
    bounds = Bounds(grey, grey, 0.5, settings, seed=0)
    return start, bounds.floor, start.refine(grey, Objective(grey, style, bounds, seed=0), settings)


def lab(image: torch.Tensor) -> torch.Tensor:
    """An RGB image's colours (3, H·W) in L*a*b* / 100."""
    return rgb_to_lab(image.flatten(1), dim=0)


def test_refining_takes_the_style_s_colours_further_within_both_bounds(grey_to_colour):
    grey, style, start, floor, refined = grey_to_colour
    before, after = (color_distance(m(grey, dim=0), style) for m in (start, refined))
    assert after < 0.7 * before  # the start gives a grey photo one hue; the style's vary with tone,
    assert refined.hue.norm(dim=1).max() > 0.05  # and the tones take hues of their own (5 ΔE or more)
    assert luminance_ssim(refined(grey, dim=0), grey) >= floor
    assert coherence(grey, refined(grey, dim=0)) <= 0.045


def test_refining_keeps_tones_in_order_and_their_steps_bounded(grey_to_colour):
    *_, refined = grey_to_colour
    steps = refined.lightness.diff() * KNOTS  # f's slope on each piece
    assert steps.min() > 0 and steps.max() <= STRETCH + 1e-5
    greys = torch.stack([torch.linspace(0, 1, 101), torch.zeros(101), torch.zeros(101)], 1)  # L*a*b* / 100
    assert refined.lab(greys)[:, 0].diff().min() > 0  # a darker tone stays darker: edges stay edges


def test_chroma_varies_only_where_the_style_s_does(grey_to_colour):
    _, colourful, *_ = grey_to_colour
    tones = texture(data.gravel())[0, 0]
    reds = lab_to_rgb(torch.stack([0.3 + 0.4 * tones, 0.3 * tones - 0.1, torch.zeros_like(tones)]), dim=0)  # a* alone varies
    assert chroma_span(lab(colourful)).equal(torch.eye(2)) and chroma_span(lab(tones.expand(3, -1, -1))).equal(torch.zeros(2, 2))
    torch.testing.assert_close(chroma_span(lab(reds)), torch.tensor([[1.0, 0.0], [0.0, 0.0]]), atol=1e-3, rtol=0)


def test_refining_toward_a_grey_style_keeps_a_grey_painting_grey(astronaut):
    grey = astronaut.mean(0, keepdim=True).expand(3, -1, -1).contiguous()
    style = (texture(data.brick())[0, 0] ** 0.5).expand(3, -1, -1)  # lighter tones than the photo's, no hue
    start, floor, fitted = refined(grey, style)
    recoloured = fitted(grey, dim=0)
    assert color_distance(recoloured, style) < 0.8 * color_distance(start(grey, dim=0), style)  # the tones move,
    assert (100 * rgb_to_lab(recoloured, dim=0)[1:]).norm(dim=0).max() < 0.5  # and no tone takes a hue (ΔE)
    assert luminance_ssim(recoloured, grey) >= floor


def test_a_share_of_the_way_blends_two_maps(grey_to_colour):
    grey, _, start, _, fitted = grey_to_colour
    assert start.toward(fitted, 0).lightness.equal(start.lightness)
    assert start.toward(fitted, 1).hue.equal(fitted.hue)
    half = start.toward(fitted, 0.5)
    colours = lab(grey).T
    torch.testing.assert_close(half.lab(colours), (start.lab(colours) + fitted.lab(colours)) / 2)


@pytest.mark.parametrize("name", ["tape", "watercolor"])
def test_recoloring_strokes_changes_colours_alone(astronaut, name):
    brush = get_brush(name)
    strokes = brush.sample(16, torch.Generator().manual_seed(0))
    recoloring = Recoloring.fit(astronaut, texture(data.gravel())[0])
    out = recoloring.strokes(brush, strokes)
    color = list(brush.color)
    others = [i for i in range(brush.d) if i not in color]
    assert torch.equal(out[:, others], strokes[:, others])
    torch.testing.assert_close(out[:, color[:3]], recoloring(strokes[:, color[:3]]))  # one map for every stroke
    assert out.min() >= 0 and out.max() <= 1


def test_coherence_is_exact_where_its_samples_cover_the_painting(astronaut):
    g = torch.Generator().manual_seed(0)
    noisy = (astronaut + 0.05 * torch.randn(astronaut.shape, generator=g)).clamp(0, 1)
    before, after = (x.flatten(1).T.double() for x in (astronaut, noisy))
    alike = torch.cdist(before, before) < NEAR
    alike.fill_diagonal_(False)
    every_pair = float(torch.cdist(after, after)[alike].mean())  # all S² pixels, each pair both ways
    assert coherence(astronaut, noisy) == pytest.approx(every_pair, rel=1e-5)
    assert coherence(astronaut, noisy, seed=1) == pytest.approx(every_pair, rel=1e-5)  # every pixel: no sampling
    sampled = [coherence(astronaut, noisy, samples=S * S // 4, seed=seed) for seed in range(3)]
    assert len(set(sampled)) == 3 and all(abs(x - every_pair) < 0.01 for x in sampled)  # a quarter: an estimate


def test_measures_of_a_stylized_painting(astronaut):
    g = torch.Generator().manual_seed(0)
    shuffled = astronaut.flatten(1)[:, torch.randperm(S * S, generator=g)].reshape(3, S, S)
    gravel = texture(data.gravel())[0]
    assert color_distance(shuffled, astronaut) < 1e-6 < 0.05 < color_distance(gravel, astronaut)
    assert luminance_ssim(astronaut, astronaut) == pytest.approx(1.0)
    assert luminance_ssim(shuffled, astronaut) < 0.2
    alike = coherence(astronaut, astronaut)  # pairs closer than 0.03 stay as close: mean below 0.03
    assert 0 < alike < 0.03
    assert coherence(astronaut, (astronaut + 0.2).clamp(max=1) - 0.1) <= alike + 0.01  # one shared shift
    noisy = (astronaut + 0.1 * torch.randn(astronaut.shape, generator=g)).clamp(0, 1)  # each pixel its own way
    assert coherence(astronaut, noisy) > 0.1
    assert texture_distance(gravel, gravel) == 0 and texture_distance(astronaut, gravel) > 0.1
    assert texture_distance(astronaut, gravel) != texture_distance(astronaut, gravel, seed=HELD_OUT_SEED + 1)
