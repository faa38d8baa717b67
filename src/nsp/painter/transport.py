"""The transportation loss (paper §3.5, SPEC §5): entropic optimal transport between pixel masses.

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
from torch.autograd.function import once_differentiable

_FLOOR = 1e-9  # per-pixel mass added before normalizing, so an empty image is a uniform one
_TAIL = -80.0  # log-ratio below which a term is raised: exp(-80) is still a normal float32


class _LogKernel(torch.autograd.Function):
    """out[m, i] = LSE_l(h[m, l] + k[i, l]): a kernel applied in the log domain.

    h: (M, n); k: (n', n), constant. Returns (M, n'). By hand rather than torch.logsumexp for two
    reasons: on CPU, exp of inputs that underflow (below about -87 in float32) takes a slow path
    costing 5-50×, and ε = 0.01 puts much of the kernel there, so terms below e^-80 of the largest
    are raised to it (a change under n·e^-80 relative); and the backward is then one batched
    matmul with the saved softmax weights instead of autograd's chain of elementwise passes.
    """

    @staticmethod
    def forward(ctx, h: Tensor, k: Tensor) -> Tensor:
        x = h[:, None, :] + k  # (M, n', n)
        top = x.amax(-1, keepdim=True)
        x.sub_(top).clamp_(min=_TAIL).exp_()
        total = x.sum(-1)  # (M, n')
        ctx.save_for_backward(x, total)  # softmax weights x / total: the derivative of LSE in h
        return total.log() + top.squeeze(-1)

    @staticmethod
    @once_differentiable
    def backward(ctx, grad: Tensor) -> tuple[Tensor, None]:
        weights, total = ctx.saved_tensors
        return torch.bmm((grad / total)[:, None, :], weights).squeeze(1), None


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
    """out[b, i, j] = LSE_{k,l}(h[b, k, l] + kr[i, k] + kc[j, l]) as two 1-D passes.

    h: (B, H, W); kr: (H, H); kc: (W, W). Returns (B, H, W).
    """
    batch, height, width = h.shape
    t = _LogKernel.apply(h.reshape(batch * height, width), kc)  # (B·H_k, W_j): columns first
    t = t.view(batch, height, width).transpose(1, 2).reshape(batch * width, height)
    return _LogKernel.apply(t, kr).view(batch, width, height).transpose(1, 2)  # (B, H_i, W_j)


def sinkhorn(a: Tensor, b: Tensor, eps: float = 0.01, iters: int = 5) -> Tensor:
    """Entropic transport cost ⟨C, P⟩ between two masses on the same grid, separable kernel.

    Args:
        a, b: (B, H, W) nonnegative masses (normalized here to sum 1; an all-zero image counts
            as uniform).
        eps: entropic regularization ε, in squared grid units (coordinates in [0, 1]).
        iters: Sinkhorn iterations (each one updates u, then v).

    Returns:
        (B,) transport costs, ≥ 0 and differentiable in a and b.
    """
    height, width = a.shape[-2:]
    scale = max(height, width)
    cr = _sq_dist(_coords(height, scale, a))  # (H, H) row part of C
    cc = _sq_dist(_coords(width, scale, a))  # (W, W) column part of C
    kr, kc = -cr / eps, -cc / eps  # log Gibbs kernel factors
    log_a, log_b = _masses(a), _masses(b)
    u = torch.zeros_like(log_a)
    v = torch.zeros_like(log_b)
    for _ in range(iters):
        u = log_a - _grid_kernel(v, kr, kc)
        v = log_b - _grid_kernel(u, kr, kc)  # C is symmetric, so the transpose is the same kernel
    # ⟨C, P⟩ = Σ P·C_rows + Σ P·C_cols, each summed in the log domain; the floor keeps log C
    # finite on the diagonal and adds under 1e-30 to the cost.
    log_cr = torch.log(cr.clamp(min=1e-30))
    log_cc = torch.log(cc.clamp(min=1e-30))
    rows = torch.logsumexp((u + _grid_kernel(v, kr + log_cr, kc)).flatten(1), dim=1)
    cols = torch.logsumexp((u + _grid_kernel(v, kr, kc + log_cc)).flatten(1), dim=1)
    return rows.exp() + cols.exp()


def dense_sinkhorn(a: Tensor, b: Tensor, eps: float = 0.01, iters: int = 5) -> Tensor:
    """The reference: :func:`sinkhorn` with the explicit (HW)×(HW) cost matrix.

    Same arguments, grid and iterations, so the two agree to rounding; O((HW)²) time and memory,
    kept for tests and the benchmark only.
    """
    height, width = a.shape[-2:]
    scale = max(height, width)
    r, c = torch.meshgrid(_coords(height, scale, a), _coords(width, scale, a), indexing="ij")
    points = torch.stack([r.flatten(), c.flatten()], dim=-1)  # (N, 2)
    cost = ((points[:, None, :] - points[None, :, :]) ** 2).sum(-1)  # (N, N)
    log_a, log_b = _masses(a).flatten(1), _masses(b).flatten(1)  # (B, N)
    u = torch.zeros_like(log_a)
    v = torch.zeros_like(log_b)
    for _ in range(iters):
        u = log_a - _LogKernel.apply(v, -cost / eps)
        v = log_b - _LogKernel.apply(u, -cost / eps)  # C is symmetric
    # (B, N, N); raising entries below e^-80 to it keeps exp off its slow path (see _LogKernel)
    # and changes the cost by under N²·e^-80
    plan = torch.exp((u[:, :, None] + v[:, None, :] - cost / eps).clamp(min=_TAIL))
    return (plan * cost).sum((1, 2))


def transport_loss(
    canvas: Tensor,
    target: Tensor,
    grid: int = 48,
    eps: float = 0.01,
    iters: int = 5,
    background: tuple[float, float, float] = (0.0, 0.0, 0.0),
) -> Tensor:
    """The painter's transportation loss L_ot between a canvas and its target.

    Both images are area-averaged to grid×grid. The mass of a pixel, per channel, is its distance
    from the blank canvas colour, |image − background|: on the default black canvas that is the
    pixel intensity (the reference implementation's mass), and on a white one it is the ink, so the
    mass is always what the strokes lay down rather than the empty background. Each channel is
    transported separately and the costs averaged: colour stays in the comparison (a red stroke
    moves towards red), and it is the deterministic expectation of the reference's one random
    channel.

    Args:
        canvas, target: (B, 3, H, W) images in [0, 1].
        grid: side of the square transport grid.
        eps, iters: Sinkhorn ε and iterations (paper: 0.01, 5).
        background: RGB in [0, 1] of the blank canvas.

    Returns:
        scalar: mean over the batch of the channel-averaged transport costs.
    """
    blank = torch.tensor(background, device=canvas.device, dtype=canvas.dtype)[:, None, None]
    masses = [
        F.adaptive_avg_pool2d((image - blank).abs(), grid).flatten(0, 1)  # (B·3, grid, grid)
        for image in (canvas, target)
    ]
    return sinkhorn(*masses, eps=eps, iters=iters).mean()
