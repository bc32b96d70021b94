#!/usr/bin/env python3
"""Check diskchungs' LPIPS against PyTorch: same random weights, several images, float64 reference.

  python3 scripts/lpips_verify.py --cli build/apps/diskchungs/diskchungs --out /tmp/lpips_verify
  python3 scripts/lpips_verify.py --cli .gpu/bundle/bin/diskchungs --out OUT   # a gpu_bundle.sh bundle

Builds torchvision's AlexNet with random weights and random non-negative LPIPS heads (no published
weights are needed), writes them with lpips_convert.py, writes image pairs as PNG, computes LPIPS
v0.1 in float64 with PyTorch from its definition, runs `diskchungs eval images --lpips-weights` on
the same PNGs and compares. Exits 1 when any pair differs by more than --tolerance (1e-4).
Needs torch and torchvision; not the lpips package, OpenCV or a network.
"""
import argparse
import json
import os
import struct
import subprocess
import sys
import time
import zlib

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
import lpips_convert  # noqa: E402


def write_png(path, rgb):
    """rgb: uint8 tensor H x W x 3 (the CLI reads 8-bit PNG; nothing else is needed to write one)."""
    h, w, _ = rgb.shape
    data = bytes(rgb.contiguous().view(-1).tolist())
    stride = 3 * w
    raw = b"".join(b"\x00" + data[y * stride:(y + 1) * stride] for y in range(h))

    def chunk(kind, payload):
        return struct.pack(">I", len(payload)) + kind + payload + struct.pack(">I", zlib.crc32(kind + payload))

    with open(path, "wb") as f:
        f.write(b"\x89PNG\r\n\x1a\n" + chunk(b"IHDR", struct.pack(">IIBBBBB", w, h, 8, 2, 0, 0, 0))
                + chunk(b"IDAT", zlib.compress(raw, 6)) + chunk(b"IEND", b""))


def image_pairs(torch, seed):
    """(name, reference, test) uint8 H x W x 3: noise, gradients, and images with noise added."""
    g = torch.Generator().manual_seed(seed)

    def noise(h, w):
        return torch.randint(0, 256, (h, w, 3), generator=g, dtype=torch.uint8)

    def smooth(h, w, phase):
        y = torch.linspace(0, 1, h, dtype=torch.float64)[:, None]
        x = torch.linspace(0, 1, w, dtype=torch.float64)[None, :]
        chans = [x + 0 * y, 0.5 + 0.45 * torch.sin(6.0 * x + 9.0 * y + phase), y * (1 - x) + 0.2 * x]
        return (torch.stack(chans, -1).clamp(0, 1) * 255).round().to(torch.uint8)

    def plus_noise(img, sigma):
        n = torch.randn(img.shape, generator=g, dtype=torch.float64) * sigma * 255
        return (img.to(torch.float64) + n).round().clamp(0, 255).to(torch.uint8)

    s1, s2, s3 = smooth(64, 96, 0.0), smooth(120, 160, 1.0), smooth(376, 1241, 2.0)
    n1 = noise(96, 128)
    return [
        ("noise_vs_noise", noise(72, 90), noise(72, 90)),
        ("gradient_vs_noisy_1pct", s1, plus_noise(s1, 0.01)),
        ("gradient_vs_noisy_5pct", s2, plus_noise(s2, 0.05)),
        ("gradient_vs_noisy_20pct", s2, plus_noise(s2, 0.20)),
        ("gradient_vs_other_gradient", s1, smooth(64, 96, 1.5)),
        ("noise_vs_itself_noisy", n1, plus_noise(n1, 0.1)),
        ("identical", s1, s1.clone()),
        ("smallest_31x31", noise(31, 31), noise(31, 31)),
        ("kitti_size_1241x376", s3, plus_noise(s3, 0.03)),
    ]


def lpips_reference(torch, features, lins, ref, test, device):
    """LPIPS v0.1 from its definition, float64: [0,1] -> [-1,1], scaling layer, the five ReLU outputs
    of AlexNet's features, unit length over channels, squared difference, 1x1 heads, spatial mean, sum."""
    shift = torch.tensor([-0.030, -0.088, -0.188], dtype=torch.float64, device=device).view(1, 3, 1, 1)
    scale = torch.tensor([0.458, 0.448, 0.450], dtype=torch.float64, device=device).view(1, 3, 1, 1)

    def taps(img):
        x = img.to(device=device, dtype=torch.float64).permute(2, 0, 1)[None] / 255.0
        x = (2 * x - 1 - shift) / scale
        outs = []
        for i, layer in enumerate(features):
            x = layer(x)
            if isinstance(layer, torch.nn.ReLU):
                outs.append(x.clone())
            if len(outs) == 5:
                break
        return outs

    total = 0.0
    for a, b, lin in zip(taps(ref), taps(test), lins):
        na = a / (torch.sqrt((a * a).sum(dim=1, keepdim=True)) + 1e-10)
        nb = b / (torch.sqrt((b * b).sum(dim=1, keepdim=True)) + 1e-10)
        d = torch.nn.functional.conv2d((na - nb) ** 2, lin)
        total += d.mean(dim=(2, 3)).item()
    return total


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--cli", required=True, help="the diskchungs binary")
    ap.add_argument("--cli-lib", default=None,
                    help="shared libraries for the CLI only (default: ../lib beside it, where gpu_bundle.sh puts them)")
    ap.add_argument("--out", required=True, help="folder for the weights, PNGs and results")
    ap.add_argument("--seed", type=int, default=1)
    ap.add_argument("--tolerance", type=float, default=1e-4)
    ap.add_argument("--device", default=None, help="torch device (default: cuda when available)")
    a = ap.parse_args()

    import torch

    device = a.device or ("cuda" if torch.cuda.is_available() else "cpu")
    if device == "cuda":
        # float64 already, but no TF32 shortcut may touch the reference either way.
        torch.backends.cuda.matmul.allow_tf32 = False
        torch.backends.cudnn.allow_tf32 = False
    os.makedirs(os.path.join(a.out, "ref"), exist_ok=True)
    os.makedirs(os.path.join(a.out, "test"), exist_ok=True)

    alexnet_state, lin_state = lpips_convert.random_state_dicts(a.seed)
    weights = os.path.join(a.out, "random_alex.dclpips")
    lpips_convert.write_dclpips(weights, lpips_convert.tensors_from_state_dicts(alexnet_state, lin_state))

    import torchvision

    net = torchvision.models.alexnet(weights=None)
    net.features.load_state_dict({k[len("features."):]: v for k, v in alexnet_state.items()})
    features = net.features.to(device=device, dtype=torch.float64).eval()
    lins = [lin_state[f"lin{l}.model.1.weight"].to(device=device, dtype=torch.float64) for l in range(5)]

    pairs = image_pairs(torch, a.seed)
    want = {}
    with torch.no_grad():
        for name, ref, test in pairs:
            write_png(os.path.join(a.out, "ref", name + ".png"), ref)
            write_png(os.path.join(a.out, "test", name + ".png"), test)
            want[name] = lpips_reference(torch, features, lins, ref, test, device)

    cmd = [a.cli, "-q", "eval", "images", "--ref", os.path.join(a.out, "ref"), "--test",
           os.path.join(a.out, "test"), "--lpips-weights", weights, "--json"]
    # Only the CLI gets the bundle's libraries: torch in this process keeps its own.
    env = dict(os.environ)
    lib = a.cli_lib or os.path.join(os.path.dirname(os.path.abspath(a.cli)), "..", "lib")
    if os.path.isdir(lib):
        env["LD_LIBRARY_PATH"] = lib + (":" + env["LD_LIBRARY_PATH"] if env.get("LD_LIBRARY_PATH") else "")
    t0 = time.time()
    run = subprocess.run(cmd, capture_output=True, text=True, env=env)
    seconds = time.time() - t0
    if run.returncode != 0:
        print(f"{' '.join(cmd)} failed ({run.returncode}):\n{run.stdout}{run.stderr}")
        return 1
    got = {im["name"]: im["lpips"] for im in json.loads(run.stdout)["images"]}

    worst = 0.0
    failed = []
    print(f"{'pair':32} {'pytorch float64':>16} {'diskchungs':>16} {'abs diff':>10}")
    for name, _, _ in pairs:
        g = got.get(name)
        if not isinstance(g, (int, float)):
            failed.append(f"{name}: no LPIPS from the CLI ({g!r})")
            continue
        diff = abs(g - want[name])
        worst = max(worst, diff)
        print(f"{name:32} {want[name]:16.9f} {g:16.9f} {diff:10.2e}")
        if diff > a.tolerance:
            failed.append(f"{name}: differs by {diff:.3e}")
    if got.get("identical") not in (0, 0.0):
        failed.append(f"identical: LPIPS {got.get('identical')!r}, expected exactly 0")
    results = {"device": device, "torch": torch.__version__, "torchvision": torchvision.__version__,
               "max_abs_diff": worst, "tolerance": a.tolerance, "cli_seconds": seconds,
               "pairs": {n: {"pytorch": want[n], "cli": got.get(n)} for n in want}, "failures": failed}
    with open(os.path.join(a.out, "lpips_verify.json"), "w") as f:
        json.dump(results, f, indent=2)
    print(f"max abs difference {worst:.3e} over {len(pairs)} pairs (tolerance {a.tolerance:g}); "
          f"CLI {seconds:.2f} s; torch {torch.__version__} on {device}")
    for f in failed:
        print("FAIL " + f)
    return 1 if failed else 0


if __name__ == "__main__":
    sys.exit(main())
