"""Style transfer (paper §3.5): losses that pull a painting toward a style image's texture
(Gram matrices of a feature network) and colours (sliced Wasserstein)."""
from nsp.style.features import (
    BACKBONES,
    RandomFeatures,
    TappedFeatures,
    WeightsNotFound,
    feature_network,
    hub_cache_path,
    random_features,
    vgg19_features,
)
from nsp.style.image import load_style_image
from nsp.style.losses import StyleLoss, gram, gram_loss, sliced_wasserstein, style_loss

__all__ = [
    "BACKBONES",
    "RandomFeatures",
    "StyleLoss",
    "TappedFeatures",
    "WeightsNotFound",
    "feature_network",
    "gram",
    "gram_loss",
    "hub_cache_path",
    "load_style_image",
    "random_features",
    "sliced_wasserstein",
    "style_loss",
    "vgg19_features",
]
