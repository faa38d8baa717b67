"""The transportation loss (paper §3.4): entropic optimal transport between pixel masses.

A pixel loss is flat in a stroke's position while the stroke does not overlap its target; the
transport cost grows with the distance the mass has to travel, so it pulls the stroke over.

Masses live on an H×W grid; pixel (i, j) sits at its centre ((i + ½)/L, (j + ½)/L), L = max(H, W),
so coordinates lie in [0, 1] and distances are isotropic. The ground cost is the squared Euclidean
distance C((i,j),(k,l)) = (r_i − r_k)² + (c_j − c_l)², which splits into a row term and a column
term, so the Gibbs kernel exp(−C/ε) is the product of an H×H and a W×W kernel: one Sinkhorn
half-iteration is two 1-D log-sum-exp passes, O(HW(H+W)), instead of one over (HW)² pairs.

Both implementations run the same log-domain iterations from zero potentials,
    u = log a − LSE_kl(v_kl − C/ε),   v = log b − LSE_ij(u_ij − C/ε),
and return ⟨C, P⟩ with P = exp(u_ij + v_kl − C/ε): after a few iterations P is only partly
converged (its column marginal is exact, its row marginal approximate), as in the paper.
"""
from __future__ import annotations

import torch
import torch.nn.functional as F
from torch import Tensor

_FLOOR = 1e-9  # per-pixel mass added before normalizing, so an empty image is a uniform one
_TAIL = -80.0  # log-ratio below which a term is raised: exp(-80) is still a normal float32


def _lse(x: Tensor, dim: int) -> Tensor:
    """torch.logsumexp over ``dim``, with every term raised to at least e^-80 of the largest: on CPU, exp
    of inputs that underflow (below about -87 in float32) takes a slow path, and ε = 0.01 puts much of
    the kernel there; the change is under n·e^-80 relative."""
    top = x.amax(dim, keepdim=True).detach()  # any shift gives the same softmax gradient
    return (x - top).clamp(min=_TAIL).exp().sum(dim).log() + top.squeeze(dim)


def _masses(a: Tensor) -> Tensor:
    """(B, H, W) nonnegative -> (B, H, W) log of the floored masses, each image summing to 1."""
    a = a.clamp(min=0) + _FLOOR
    return torch.log(a) - torch.log(a.sum((-2, -1), keepdim=True))


def _coords(n: int, scale: int, like: Tensor) -> Tensor:
    """Centres of n pixels along one axis, (n,) in [0, 1], for a grid whose longer side is scale."""
    return (torch.arange(n, device=like.device, dtype=like.dtype) + 0.5) / scale


def _sq_dist(x: Tensor) -> Tensor:
    """(n,) coordinates -> (n, n) squared distances."""
    return (x[:, None] - x[None, :]) ** 2


def _grid_kernel(h: Tensor, kr: Tensor, kc: Tensor) -> Tensor:
    """out[b, i, j] = LSE_{k,l}(h[b, k, l] + kr[i, k] + kc[j, l]) as two 1-D passes: h (B, H, W), kr (H, H),
    kc (W, W) -> (B, H, W)."""
    t = _lse(h[:, :, None, :] + kc, dim=-1)  # (B, H_k, W_j): columns first
    return _lse(t[:, None, :, :] + kr[None, :, :, None], dim=2)  # (B, H_i, W_j)


def sinkhorn(a: Tensor, b: Tensor, eps: float = 0.01, iters: int = 5) -> Tensor:
    """Entropic transport costs ⟨C, P⟩ (B,), ≥ 0 and differentiable, between two masses on the same
    grid, by the separable kernel.

    Args:
        a, b: (B, H, W) nonnegative masses (normalized here to sum 1; an all-zero image counts as uniform).
        eps: entropic regularization ε, in the units of C (squared distance, coordinates in [0, 1]).
        iters: Sinkhorn iterations (each one updates u, then v).
    """
    height, width = a.shape[-2:]
    scale = max(height, width)
    cr, cc = _sq_dist(_coords(height, scale, a)), _sq_dist(_coords(width, scale, a))  # C's (H, H) and (W, W) parts
    kr, kc = -cr / eps, -cc / eps  # log Gibbs kernel factors
    log_a, log_b = _masses(a), _masses(b)
    u, v = torch.zeros_like(log_a), torch.zeros_like(log_b)
    for _ in range(iters):
        u = log_a - _grid_kernel(v, kr, kc)
        v = log_b - _grid_kernel(u, kr, kc)  # C is symmetric, so the transpose is the same kernel
    # ⟨C, P⟩ = Σ P·C_rows + Σ P·C_cols, each summed in the log domain; the floor keeps log C
    # finite on the diagonal and adds under 1e-30 to the cost.
    log_cr, log_cc = torch.log(cr.clamp(min=1e-30)), torch.log(cc.clamp(min=1e-30))
    rows = torch.logsumexp((u + _grid_kernel(v, kr + log_cr, kc)).flatten(1), dim=1)
    cols = torch.logsumexp((u + _grid_kernel(v, kr, kc + log_cc)).flatten(1), dim=1)
    return rows.exp() + cols.exp()


def dense_sinkhorn(a: Tensor, b: Tensor, eps: float = 0.01, iters: int = 5) -> Tensor:
    """The reference: :func:`sinkhorn` with the explicit (HW)×(HW) cost matrix, the same arguments,
    grid and iterations, so the two agree to rounding; O((HW)²) time and memory, for tests and benchmarks."""
    height, width = a.shape[-2:]
    scale = max(height, width)
    r, c = torch.meshgrid(_coords(height, scale, a), _coords(width, scale, a), indexing="ij")
    points = torch.stack([r.flatten(), c.flatten()], dim=-1)  # (N, 2)
    cost = ((points[:, None, :] - points[None, :, :]) ** 2).sum(-1)  # (N, N)
    kernel = -cost / eps  # log Gibbs kernel
    log_a, log_b = _masses(a).flatten(1), _masses(b).flatten(1)  # (B, N)
    u, v = torch.zeros_like(log_a), torch.zeros_like(log_b)
    for _ in range(iters):
        u = log_a - _lse(v[:, None, :] + kernel, dim=2)
        v = log_b - _lse(u[:, :, None] + kernel, dim=1)
    # (B, N, N); entries raised to e^-80 keep exp off its slow path (see _lse), changing the cost under N²·e^-80
    plan = torch.exp((u[:, :, None] + v[:, None, :] + kernel).clamp(min=_TAIL))
    return (plan * cost).sum((1, 2))


def transport_loss(canvas: Tensor, target: Tensor, grid: int, eps: float, iters: int,
                   background: tuple[float, float, float] = (0.0, 0.0, 0.0)) -> Tensor:
    """The painter's transportation loss L_ot between ``canvas`` and ``target`` (B, 3, H, W) in [0, 1]:
    a scalar, the batch's mean channel-averaged transport cost, by Sinkhorn (``eps``, ``iters``;
    paper: 0.01, 5) on both area-averaged to ``grid``×``grid``. A pixel's mass, per channel, is
    |image − background| (RGB in [0, 1] of the blank canvas): the intensity on a black canvas (the
    reference implementation's mass), the ink on a white one, what the strokes lay down. Each channel
    is transported apart and the costs averaged: colour stays in the comparison, the deterministic
    expectation of the reference's one random channel."""
    blank = torch.stack([canvas.new_full((), value) for value in background])[:, None, None]  # filled, not copied in
    masses = [F.adaptive_avg_pool2d((image - blank).abs(), grid).flatten(0, 1)  # (B·3, grid, grid)
              for image in (canvas, target)]
    return sinkhorn(*masses, eps=eps, iters=iters).mean()
