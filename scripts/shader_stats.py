#!/usr/bin/env python3
"""Static size of the Vulkan path's shaders, from their SPIR-V (spirv-dis --raw-id).

Per module: instructions inside function bodies (what glslc -O leaves after inlining:
the measure docs/vulkan.md and experiments/GPU.md use), blocks, double-precision
arithmetic (float64 results of arithmetic, extended and select instructions, float64
operands of comparisons) and whether the module declares the Float64 capability (a GPU
without shaderFloat64 cannot load it). Step counts and shader sizes are deterministic,
so a budget may be asserted: with --budget FILE, a module larger than its ceiling there
fails the run (exit 1), naming the module, the count and the ceiling.

    scripts/shader_stats.py build/vulkan_shaders [--budget render/vulkan/shaders/budget.json] [--json]
"""
import argparse
import json
import pathlib
import re
import subprocess
import sys

ARITH = {"OpFAdd", "OpFSub", "OpFMul", "OpFDiv", "OpFNegate", "OpFMod", "OpFRem", "OpDot",
         "OpVectorTimesScalar", "OpExtInst", "OpSelect"}
COMPARE_PREFIXES = ("OpFOrd", "OpFUnord", "OpIsNan", "OpIsInf")
LINE = re.compile(r"\s*(?:(%\S+)\s*=\s*)?(Op\w+)\s*(.*)")


def stats(spv: pathlib.Path) -> dict:
    text = subprocess.run(["spirv-dis", "--raw-id", str(spv)], check=True, capture_output=True,
                          text=True).stdout
    types, result_type = {}, {}
    body = []
    in_function = False
    capabilities = set()
    for raw in text.splitlines():
        m = LINE.match(raw.split(";")[0])
        if not m:
            continue
        rid, op, rest = m.groups()
        operands = rest.split()
        if op == "OpCapability":
            capabilities.add(operands[0])
        if op == "OpFunction":
            in_function = True
        if op == "OpFunctionEnd":
            in_function = False
        if in_function:
            body.append((op, operands))
        if rid and op.startswith("OpType"):
            types[rid] = (op, operands)
        elif rid and operands and operands[0].startswith("%"):
            result_type[rid] = operands[0]

    def is_f64(tid: str) -> bool:
        op, t = types.get(tid, ("", []))
        if op == "OpTypeVector":
            return is_f64(t[0])
        return op == "OpTypeFloat" and t[0] == "64"

    f64 = 0
    for op, operands in body:
        if op in ARITH and operands and is_f64(operands[0]):
            f64 += 1
        elif op.startswith(COMPARE_PREFIXES) and len(operands) > 1 and is_f64(result_type.get(operands[1], "")):
            f64 += 1
    return {
        "instructions": len(body),
        "blocks": sum(1 for op, _ in body if op == "OpLabel"),
        "f64_operations": f64,
        "float64_capability": "Float64" in capabilities,
    }


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("spv_dir", type=pathlib.Path, help="the build's vulkan_shaders/ folder")
    ap.add_argument("--budget", type=pathlib.Path, help="JSON {module: {instructions: ceiling}}")
    ap.add_argument("--json", action="store_true", help="print the counts as JSON")
    args = ap.parse_args()
    modules = sorted(args.spv_dir.glob("*.spv"))
    if not modules:
        print(f"shader_stats: {args.spv_dir}: no .spv files (build the Vulkan path first)", file=sys.stderr)
        return 1
    counts = {p.stem: stats(p) for p in modules}
    if args.json:
        print(json.dumps(counts, indent=2))
    else:
        print(f"{'module':<16} {'instructions':>12} {'blocks':>7} {'f64 ops':>8}  Float64")
        for name, c in counts.items():
            print(f"{name:<16} {c['instructions']:>12} {c['blocks']:>7} {c['f64_operations']:>8}  "
                  f"{'yes' if c['float64_capability'] else 'no'}")
    if "prism.rint" in counts and "tfdm.rint" in counts:
        ratio = counts["prism.rint"]["instructions"] / counts["tfdm.rint"]["instructions"]
        with_f64 = [n for n, c in counts.items() if c["float64_capability"]]
        print(f"canonical / tfdm intersection shader: {ratio:.2f}x the instructions; "
              f"modules declaring Float64: {', '.join(with_f64) or 'none'}")
    if args.budget:
        budget = json.loads(args.budget.read_text())
        failed = False
        for name, ceiling in budget.get("ceilings", {}).items():
            if name not in counts:
                print(f"shader_stats: {args.budget}: no module {name} in {args.spv_dir}", file=sys.stderr)
                failed = True
            elif counts[name]["instructions"] > ceiling:
                print(f"shader_stats: {name}: {counts[name]['instructions']} instructions, over its budget of "
                      f"{ceiling} ({args.budget})", file=sys.stderr)
                failed = True
        # Only the modules the budget lists may declare Float64 (a GPU without
        # shaderFloat64 cannot load the others either).
        allowed = set(budget.get("float64_allowed", []))
        for name, c in counts.items():
            if c["float64_capability"] and name not in allowed:
                print(f"shader_stats: {name}: declares the Float64 capability, which {args.budget} allows only "
                      f"in {', '.join(sorted(allowed)) or 'no module'}", file=sys.stderr)
                failed = True
        if failed:
            return 1
    return 0


if __name__ == "__main__":
    sys.exit(main())
