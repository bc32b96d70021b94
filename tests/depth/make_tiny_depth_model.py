#!/usr/bin/python3
"""Writes a tiny ONNX "depth model" for tests/depth/learned_depth_test.cpp, with Debian's python3-onnx.

Every model is a 1x1 convolution of the normalised RGB planes (weights W, bias B below), so its output
at a pixel is B + sum_c W[c] * x_c and the test computes it exactly. Kinds:
  good         input [1, 3, H, W] -> output [1, 1, H, W]
  dynamic      as good, with H and W dynamic ('height', 'width')
  rank3        as good, output reshaped to [1, H, W]
  depth        as good with a positive output and metadata chungs.output = depth
  meta         as good with metadata chungs.mean / chungs.std (--mean, --std)
  gray_input   input [1, 1, H, W]            (breaks the contract)
  rgb_output   output [1, 3, H, W]           (breaks the contract)
  two_inputs   two inputs added              (breaks the contract)
  bad_meta     metadata chungs.mean = '1, 2' (breaks the contract)
"""
import argparse

import onnx
from onnx import TensorProto, helper

W = [0.5, -0.25, 2.0]
B = 0.1
W_DEPTH = [0.5, 0.25, 0.125]  # with B_DEPTH the output stays above 3 - 0.875 * 3 > 0 for inputs in [-3, 3]
B_DEPTH = 3.0


def conv(name, x, out, in_ch, weights, bias):
    out_ch = len(weights) // in_ch
    w = helper.make_tensor(name + "_w", TensorProto.FLOAT, [out_ch, in_ch, 1, 1], weights)
    b = helper.make_tensor(name + "_b", TensorProto.FLOAT, [out_ch], bias)
    return helper.make_node("Conv", [x, name + "_w", name + "_b"], [out], name=name), [w, b]


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--out", required=True)
    ap.add_argument("--kind", default="good")
    ap.add_argument("--height", type=int, default=12)
    ap.add_argument("--width", type=int, default=16)
    ap.add_argument("--mean", default="0.5,0.25,0.75")
    ap.add_argument("--std", default="0.5,0.125,2")
    a = ap.parse_args()
    k = a.kind
    h, w = (("height", "width") if k == "dynamic" else (a.height, a.width))
    in_ch = 1 if k == "gray_input" else 3
    inputs = [helper.make_tensor_value_info("image", TensorProto.FLOAT, [1, in_ch, h, w])]
    nodes, inits = [], []
    x = "image"
    if k == "two_inputs":
        inputs.append(helper.make_tensor_value_info("other", TensorProto.FLOAT, [1, 3, h, w]))
        nodes.append(helper.make_node("Add", ["image", "other"], ["sum"]))
        x = "sum"
    if k == "gray_input":
        weights, bias = [1.0], [0.0]
    elif k == "rgb_output":
        weights, bias = W * 3, [B] * 3
    elif k == "depth":
        weights, bias = W_DEPTH, [B_DEPTH]
    else:
        weights, bias = W, [B]
    out_ch = len(weights) // in_ch
    node, init = conv("mix", x, "conv", in_ch, weights, bias)
    nodes.append(node)
    inits += init
    if k == "rank3":
        shape = helper.make_tensor("shape", TensorProto.INT64, [3], [1, a.height, a.width])
        inits.append(shape)
        nodes.append(helper.make_node("Reshape", ["conv", "shape"], ["depth"]))
        out_shape = [1, a.height, a.width]
    else:
        nodes.append(helper.make_node("Identity", ["conv"], ["depth"]))
        out_shape = [1, out_ch, h, w]
    outputs = [helper.make_tensor_value_info("depth", TensorProto.FLOAT, out_shape)]
    graph = helper.make_graph(nodes, "tiny_depth", inputs, outputs, inits)
    model = helper.make_model(graph, opset_imports=[helper.make_opsetid("", 13)], producer_name="diskchungs-tests")
    model.ir_version = 7  # read by every ONNX Runtime from 1.8 on
    meta = {}
    if k == "depth":
        meta["chungs.output"] = "depth"
    if k == "meta":
        meta["chungs.mean"], meta["chungs.std"] = a.mean, a.std
    if k == "bad_meta":
        meta["chungs.mean"] = "1, 2"
    helper.set_model_props(model, meta)
    onnx.checker.check_model(model)
    onnx.save(model, a.out)


if __name__ == "__main__":
    main()
