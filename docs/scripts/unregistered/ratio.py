"""A capture's surface error against the registered sequence's at equal bits.

The registered rows (bits a vertex a frame, surface RMS %) make a curve,
read by linear interpolation between its points and extended along its
first or last segment past them; each of our rows' error is divided by the
curve's at our bits. Past the registered curve's last point (more bits than
its finest file) the extension may run under the curve's floor, so such a
ratio is marked.

    python docs/scripts/unregistered/ratio.py \
        --registered 26.849,0.0275 8.535,0.0457 4.581,0.0665 \
        --ours 25.309,0.0597 6.638,0.1351 3.256,0.2037
"""
import argparse


def point(text):
    bits, err = text.split(",")
    return float(bits), float(err)


def registered_error(curve, bits):
    """The registered curve's error at `bits` (sorted by bits)."""
    if bits <= curve[0][0]:
        (b0, e0), (b1, e1) = curve[0], curve[1]
    elif bits >= curve[-1][0]:
        (b0, e0), (b1, e1) = curve[-2], curve[-1]
    else:
        i = next(i for i in range(len(curve) - 1) if curve[i][0] <= bits <= curve[i + 1][0])
        (b0, e0), (b1, e1) = curve[i], curve[i + 1]
    return e0 + (e1 - e0) * (bits - b0) / (b1 - b0)


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--registered", nargs="+", type=point, required=True, help="BITS,ERR of each registered row")
    ap.add_argument("--ours", nargs="+", type=point, required=True, help="BITS,ERR of each row to compare")
    args = ap.parse_args()
    curve = sorted(args.registered)
    if len(curve) < 2:
        ap.error("the registered curve needs two rows or more")
    for bits, err in args.ours:
        ratio = err / registered_error(curve, bits)
        past = " (past the registered curve's last point)" if bits > curve[-1][0] else ""
        print(f"{bits:.3f} b/v/f, {err:.4f} %: {ratio:.2f}x the registered error at equal bits{past}")


if __name__ == "__main__":
    main()
