"""Mean FLIP (LDR, default 67 pixels per degree) of image pairs, with NVIDIA's
flip-evaluator package. Usage: flip.py REF TEST [REF TEST ...]; prints one
mean per pair, in order."""
import sys

import flip_evaluator as flip

args = sys.argv[1:]
for ref, test in zip(args[0::2], args[1::2]):
    _, mean, _ = flip.evaluate(ref, test, "LDR", applyMagma=False)
    print(f"{mean:.6f}")
