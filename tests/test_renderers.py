"""Neural renderers: every family × brush builds with the right output, the dual factorisation holds."""
from pathlib import Path

import pytest
import torch
from hydra import compose, initialize_config_dir

from nsp.brushes import BRUSHES
from nsp.renderers import SIZES, DualPathway, build
from nsp.training.schema import register_configs

pytestmark = pytest.mark.numerics  # make test runs these under other CPU kernels too

CONF = Path(__file__).parents[1] / "conf" / "train"
RENDERERS = sorted(p.stem for p in (CONF / "renderer").glob("*.yaml"))
SMALL = 0.125  # width multiplier that keeps the tests fast


def renderer_config(name: str, size: int = 32, width: float = SMALL) -> dict:
    """The real ``conf/train/renderer/<name>.yaml``, resolved at ``size`` and ``width``."""
    register_configs()
    with initialize_config_dir(str(CONF), version_base="1.3"):
        cfg = compose("train", overrides=[f"renderer={name}", f"model.size={size}", f"model.channel_mult={width}"])
    return {k: cfg.renderer[k] for k in cfg.renderer}


@pytest.mark.parametrize("brush", list(BRUSHES))
@pytest.mark.parametrize("name", RENDERERS)
def test_every_renderer_and_brush_gives_images_in_range(name, brush):
    renderer = build(renderer_config(name), brush).eval()
    x = BRUSHES[brush].sample(3, generator=torch.Generator().manual_seed(0))
    with torch.no_grad():
        fg, alpha = renderer(x)
    assert fg.shape == (3, 3, 32, 32) and alpha.shape == (3, 1, 32, 32)
    for image in (fg, alpha):
        assert image.min() >= 0 and image.max() <= 1


@pytest.mark.parametrize("size", SIZES)
def test_sizes(size):
    fg, alpha = DualPathway("tape", size, SMALL)(torch.rand(2, 8))
    assert fg.shape == (2, 3, size, size) and alpha.shape == (2, 1, size, size)


def test_other_sizes_are_refused_naming_the_valid_ones():
    with pytest.raises(ValueError, match="32, 64, 128"):
        DualPathway("tape", 48)


def test_paper_layers_at_width_one():
    """At S = 128 and width 1 the pathways have the appendix tables' filters."""
    net = DualPathway("oilpaint", 128, 1.0)
    deconvs = [m for m in net.shading.modules() if isinstance(m, torch.nn.ConvTranspose2d)]
    assert [m.out_channels for m in deconvs] == [512, 512, 256, 128, 64, 3]
    linears = [m.out_features for m in net.rasterization.modules() if isinstance(m, torch.nn.Linear)]
    assert linears == [512, 1024, 2048, 4096]
    convs = [m.out_channels for m in net.rasterization.modules() if isinstance(m, torch.nn.Conv2d)]
    assert convs == [32, 32, 16, 16, 8, 4 * 2]  # two silhouettes (support, coverage) where the paper has one


def test_dual_alpha_is_transparency_times_silhouette():
    """α = A · coverage: zero where the silhouette is, and colour or transparency never move the silhouette."""
    torch.manual_seed(0)
    brush = BRUSHES["watercolor"]
    net = DualPathway("watercolor", 32, SMALL).eval()
    x = brush.sample(4)
    with torch.no_grad():
        _, _, coverage = net.maps(x)
        assert torch.equal(net(x)[1], x[:, brush.alpha, None, None, None] * coverage)

        recoloured = x.clone()
        recoloured[:, [*brush.color, brush.alpha]] = torch.rand(4, len(brush.color) + 1)
        assert torch.equal(net.maps(recoloured)[2], coverage)

        net.rasterization.convs[-2].bias[4:8] = -1e4  # the channels the pixel shuffle makes the coverage
        assert torch.count_nonzero(net(x)[1]) == 0


@pytest.mark.parametrize("pathways", [["rasterization", "shading"], ["rasterization"], ["shading"]])
def test_one_silhouette_is_both_support_and_coverage(pathways):
    """silhouettes=1, the paper's renderer: s = colour · silhouette and α = A · silhouette, one map."""
    brush = BRUSHES["watercolor"]
    net = DualPathway("watercolor", 32, SMALL, pathways, silhouettes=1).eval()
    x = brush.sample(3)
    with torch.no_grad():
        colour, support, coverage = net.maps(x)
        fg, alpha = net(x)
    assert support is coverage and support.shape == (3, 1, 32, 32)
    assert torch.equal(fg, colour * coverage) and torch.equal(alpha, x[:, brush.alpha, None, None, None] * coverage)
    if len(pathways) == 2:
        assert net.rasterization.convs[-2].out_channels == 4  # one map through the ×2 pixel shuffle


def test_silhouettes_other_than_one_or_two_are_refused():
    with pytest.raises(ValueError, match="silhouettes=3: expected 1"):
        DualPathway("tape", 32, SMALL, silhouettes=3)
