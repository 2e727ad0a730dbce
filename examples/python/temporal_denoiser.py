"""A small recurrent temporal denoiser in PyTorch, Tandem's Python example (docs/python.md).

Per frame it reads the noisy radiance and the G-buffer (albedo, normal, depth, motion), warps its
own previous output along the motion vectors (bilinear, with a disocclusion test on depth), and
predicts per pixel a 5 x 5 filter over the demodulated noisy radiance (irradiance: radiance over
albedo) and a blend weight between that filtered frame and the warped history; the result is
modulated by the albedo again. 8,122 parameters. It is trained by train.py on `tandem dataset`
frames against matched references and runs inside Tandem's frame loop:

    tandem render --denoiser python:temporal_denoiser:Denoiser ...   (PYTHONPATH=examples/python)

or from the package: ``tandem.Renderer(scene, denoiser=temporal_denoiser.Denoiser)``. The
weights come from TANDEM_EXAMPLE_WEIGHTS, else temporal_denoiser.pt beside this file.
"""
import os

import numpy as np
import torch
import torch.nn.functional as F

K = 5  # the filter's width
EPS_ALBEDO = 0.02  # demodulation floor (dark albedo: radiance stays radiance)


class Net(torch.nn.Module):
    """features (14) -> 16 -> 16 -> K*K filter logits + 1 blend logit"""

    IN = 14

    def __init__(self):
        super().__init__()
        self.c1 = torch.nn.Conv2d(self.IN, 16, 3, padding=1)
        self.c2 = torch.nn.Conv2d(16, 16, 3, padding=1)
        self.c3 = torch.nn.Conv2d(16, K * K + 1, 3, padding=1)

    def forward(self, x):
        x = F.leaky_relu(self.c1(x), 0.1)
        x = F.leaky_relu(self.c2(x), 0.1)
        return self.c3(x)


def warp(prev, motion):
    """prev (N, C, H, W) at each pixel's previous position: motion (N, 2, H, W) is previous
    minus current in pixels (Tandem's contract)."""
    n, _, h, w = prev.shape
    ys, xs = torch.meshgrid(torch.arange(h, dtype=prev.dtype), torch.arange(w, dtype=prev.dtype),
                            indexing="ij")
    px = xs[None] + motion[:, 0]
    py = ys[None] + motion[:, 1]
    # pixel centres to grid_sample's [-1, 1] (align_corners=False)
    grid = torch.stack(((px + 0.5) / w * 2 - 1, (py + 0.5) / h * 2 - 1), dim=-1)
    inside = ((px >= -0.5) & (px <= w - 0.5) & (py >= -0.5) & (py <= h - 0.5)).to(prev.dtype)
    return F.grid_sample(prev, grid, mode="bilinear", padding_mode="border",
                         align_corners=False), inside[:, None]


def features(noisy, albedo, normal, depth, motion, prev_out, prev_depth):
    """Tensors (N, C, H, W) -> the network's input, the demodulated radiance, the warped
    history and its validity."""
    irr = noisy / (albedo + EPS_ALBEDO)
    if prev_out is None:
        hist = torch.zeros_like(noisy)
        valid = torch.zeros_like(depth)
    else:
        hist, inside = warp(torch.cat((prev_out, prev_depth), 1), motion[:, :2])
        hist, hdepth = hist[:, :3], hist[:, 3:4]
        # the same surface: the previous depth there within 5% of this one's (plus the motion's
        # depth change)
        expect = depth + motion[:, 2:3]
        valid = inside * (torch.abs(hdepth - expect) <= 0.05 * expect.clamp(min=1e-3)).to(depth.dtype)
        valid = valid * (depth < 1e20).to(depth.dtype)
    d = torch.where(depth < 1e20, depth, torch.zeros_like(depth))
    dn = d / (d.amax(dim=(2, 3), keepdim=True) + 1e-6)
    x = torch.cat((torch.log1p(noisy), albedo, normal, dn, torch.log1p(hist / (albedo + EPS_ALBEDO)) * valid,
                   valid), 1)
    return x, irr, hist, valid


def step(net, noisy, albedo, normal, depth, motion, prev_out, prev_depth):
    """One frame: the denoised radiance (N, 3, H, W)."""
    x, irr, hist, valid = features(noisy, albedo, normal, depth, motion, prev_out, prev_depth)
    y = net(x)
    w = torch.softmax(y[:, :K * K], dim=1)  # (N, K*K, H, W)
    n, _, h, wd = irr.shape
    patches = F.unfold(irr, K, padding=K // 2).view(n, 3, K * K, h, wd)
    filtered = (patches * w[:, None]).sum(2) * (albedo + EPS_ALBEDO)
    alpha = torch.sigmoid(y[:, K * K:]) * valid  # the history's share
    return alpha * hist + (1 - alpha) * filtered


def default_weights():
    return os.environ.get("TANDEM_EXAMPLE_WEIGHTS") or os.path.join(
        os.path.dirname(os.path.abspath(__file__)), "temporal_denoiser.pt")


def _t(a):
    """(H, W, C) numpy -> (1, C, H, W) tensor (a copy: Tandem's buffers are reused)"""
    return torch.from_numpy(np.array(np.asarray(a, np.float32).transpose(2, 0, 1)))[None]


class Denoiser:
    """The trained network in Tandem's frame loop (python:temporal_denoiser:Denoiser)."""

    def __init__(self, width, height, weights=None):
        torch.set_num_threads(max(1, os.cpu_count() or 1))
        self.net = Net()
        self.net.load_state_dict(torch.load(weights or default_weights(), map_location="cpu"))
        self.net.eval()
        self.prev = self.prev_depth = None

    @torch.no_grad()
    def __call__(self, frame):
        noisy = _t(frame.radiance)
        depth = _t(frame["depth"])
        if frame.reset:
            self.prev = self.prev_depth = None
        out = step(self.net, noisy, _t(frame["albedo"]), _t(frame["normal"]), depth,
                   _t(frame["motion"]), self.prev, self.prev_depth)
        self.prev, self.prev_depth = out, depth
        return out[0].numpy().transpose(1, 2, 0)
