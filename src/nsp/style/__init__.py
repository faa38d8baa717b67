"""Style transfer (paper §3.5): losses that pull a painting toward a style image's texture
(Gram matrices of a feature network) and colours (sliced Wasserstein), the recolouring shared by
a whole painting, and the measures of a stylized painting (:mod:`nsp.style.measures`)."""
from nsp.style.features import (MIN_SIDE, RandomFeatures, TappedFeatures, WeightsNotFound, feature_network,
                                hub_cache_path, random_features, vgg19_features)
from nsp.style.losses import StyleLoss, gram, gram_loss, sliced_wasserstein, style_loss
from nsp.style.recolor import Recoloring

__all__ = ["MIN_SIDE", "RandomFeatures", "Recoloring", "StyleLoss", "TappedFeatures", "WeightsNotFound",
           "feature_network", "gram", "gram_loss", "hub_cache_path", "random_features", "sliced_wasserstein",
           "style_loss", "vgg19_features"]
