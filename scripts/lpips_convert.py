#!/usr/bin/env python3
"""Write LPIPS (v0.1, 'alex') weights as a DCLPIPS1 file for `diskchungs --lpips-weights`.

The published weights come in two PyTorch files:
  * torchvision's ImageNet AlexNet, alexnet-owt-7be5be79.pth (keys features.N.weight / .bias);
  * the LPIPS heads of the lpips package, lpips/weights/v0.1/alex.pth (keys linK.model.1.weight).

  lpips_convert.py --alexnet alexnet-owt-7be5be79.pth --lin alex.pth --out lpips_alex.dclpips
  lpips_convert.py --random 7 --out random.dclpips     # torchvision's initialisation, seeded

Reading .pth files needs PyTorch (and --random torchvision); writing the file itself needs neither.
The format is described in src/chungs/eval/LPIPS_WEIGHTS.md.
"""
import argparse
import array
import struct
import sys
import zlib

MAGIC = b"DCLPIPS1"
VERSION = 1
# (torchvision features index, out, in, kernel) of AlexNet's five convolutions.
CONVS = [(0, 64, 3, 11), (3, 192, 64, 5), (6, 384, 192, 3), (8, 256, 384, 3), (10, 256, 256, 3)]


def tensor_specs():
    """Names and shapes in file order, as the C++ reader expects them."""
    specs = []
    for idx, out, inp, k in CONVS:
        specs.append((f"features.{idx}.weight", (out, inp, k, k)))
        specs.append((f"features.{idx}.bias", (out,)))
    for layer, (_, out, _, _) in enumerate(CONVS):
        specs.append((f"lin{layer}.weight", (1, out, 1, 1)))
    return specs


def float32_bytes(values):
    a = array.array("f", values)
    if sys.byteorder != "little":
        a.byteswap()
    return a.tobytes()


def dclpips_bytes(tensors):
    """tensors: name -> (shape, flat sequence of floats in row-major order)."""
    out = bytearray(MAGIC)
    specs = tensor_specs()
    out += struct.pack("<II", VERSION, len(specs))
    for name, shape in specs:
        if name not in tensors:
            raise ValueError(f"missing tensor {name}")
        got_shape, values = tensors[name]
        if tuple(got_shape) != shape:
            raise ValueError(f"{name} has shape {tuple(got_shape)}, expected {shape}")
        count = 1
        for d in shape:
            count *= d
        if len(values) != count:
            raise ValueError(f"{name} has {len(values)} values, expected {count}")
        if name.startswith("lin") and min(values) < 0:
            raise ValueError(f"{name} has negative weights: not LPIPS heads (they are clamped to >= 0)")
        encoded = name.encode("ascii")
        out += struct.pack("<I", len(encoded)) + encoded
        out += struct.pack("<I", len(shape)) + struct.pack(f"<{len(shape)}I", *shape)
        out += float32_bytes(values)
    out += struct.pack("<I", zlib.crc32(bytes(out)) & 0xFFFFFFFF)
    return bytes(out)


def write_dclpips(path, tensors):
    data = dclpips_bytes(tensors)
    with open(path, "wb") as f:
        f.write(data)
    return len(data)


def find_key(state, suffix, source):
    """The one key ending in `suffix` (checkpoints saved from wrappers add prefixes such as net.)."""
    hits = [k for k in state if k == suffix or k.endswith("." + suffix)]
    if len(hits) != 1:
        raise KeyError(f"{source}: expected one key ending in {suffix}, found {hits or 'none'}")
    return hits[0]


def tensors_from_state_dicts(alexnet_state, lin_state, alexnet_source="alexnet", lin_source="lin"):
    import torch

    def flat(t):
        return tuple(t.shape), t.detach().to(torch.float32).cpu().contiguous().view(-1).tolist()

    tensors = {}
    for idx, _, _, _ in CONVS:
        for part in ("weight", "bias"):
            key = find_key(alexnet_state, f"features.{idx}.{part}", alexnet_source)
            tensors[f"features.{idx}.{part}"] = flat(alexnet_state[key])
    for layer in range(len(CONVS)):
        key = find_key(lin_state, f"lin{layer}.model.1.weight", lin_source)
        tensors[f"lin{layer}.weight"] = flat(lin_state[key])
    return tensors


def random_state_dicts(seed):
    """torchvision's AlexNet as initialised (untrained) and uniform [0, 1) heads, from one seed."""
    import torch
    import torchvision

    torch.manual_seed(seed)
    net = torchvision.models.alexnet(weights=None)
    alexnet_state = {k: v for k, v in net.state_dict().items() if k.startswith("features.")}
    gen = torch.Generator().manual_seed(seed + 1)
    lin_state = {f"lin{l}.model.1.weight": torch.rand((1, out, 1, 1), generator=gen)
                 for l, (_, out, _, _) in enumerate(CONVS)}
    return alexnet_state, lin_state


def load_state_dict(path):
    import torch

    state = torch.load(path, map_location="cpu", weights_only=True)
    if isinstance(state, dict) and "state_dict" in state and isinstance(state["state_dict"], dict):
        state = state["state_dict"]
    return state


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--alexnet", help="torchvision AlexNet state dict (.pth)")
    ap.add_argument("--lin", help="LPIPS v0.1 alex heads (.pth, from the lpips package)")
    ap.add_argument("--random", type=int, metavar="SEED", help="random weights instead (for verification)")
    ap.add_argument("--out", required=True, help="DCLPIPS1 file to write")
    a = ap.parse_args()
    if a.random is not None:
        if a.alexnet or a.lin:
            ap.error("--random writes random weights; it takes no --alexnet or --lin")
        tensors = tensors_from_state_dicts(*random_state_dicts(a.random))
    else:
        if not (a.alexnet and a.lin):
            ap.error("give --alexnet and --lin (or --random SEED)")
        tensors = tensors_from_state_dicts(load_state_dict(a.alexnet), load_state_dict(a.lin), a.alexnet, a.lin)
    size = write_dclpips(a.out, tensors)
    print(f"{a.out}: {size} bytes, {len(tensors)} tensors")


if __name__ == "__main__":
    main()
