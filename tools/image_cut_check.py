#!/usr/bin/env python3
"""Compare vlm-client's image check with Pillow's on pictures cut short.

vlm-client decodes every PNG or JPEG before it sends it (`Image::from_bytes`), so that a
truncated or corrupt picture is bad input here, not a server's 400. Servers load pictures with
Pillow (vLLM) or similar. This script makes, with Pillow, a PNG, a baseline JPEG, a progressive
JPEG, a JPEG with an EXIF segment and one with stray bytes between segments, cuts each at many
lengths (every byte of the first and last 64, and 64 between), and asks both: Pillow
(`Image.open(...).load()`, truncated images not allowed, its default) and our `xtask chat
--image` (exit 2: the image is refused; exit 3 with "cannot connect": it was accepted and the
request went to a closed port).

It also asks both about PNG headers that claim a size one pixel row past Pillow's
decompression-bomb limit (2 * Image.MAX_IMAGE_PIXELS, refused by `Image.open`) and one row
under it (opened, then cut short): both must refuse the first at its header, and ours must say
so by its size.

Usage: python3 tools/image_cut_check.py [--xtask PATH]   (needs Pillow; `pip install pillow`)
Prints one line per picture with every disagreement, then a JSON summary. Exit 0 when the only
disagreements are PNG cuts inside the last 20 bytes (the IDAT chunk's CRC and zlib checksum
and the IEND chunk), where Pillow reads the pixel data without its checksums and the png
decoder here wants them; exit 1 on any other disagreement, 2 on bad usage.
"""

import argparse
import io
import json
import os
import random
import subprocess
import sys
import tempfile
import warnings
import zlib

try:
    from PIL import Image
except ImportError:
    sys.exit("image_cut_check.py needs Pillow (pip install pillow)")


def pictures():
    rng = random.Random(7)
    img = Image.frombytes("RGB", (64, 48), bytes(rng.randrange(256) for _ in range(64 * 48 * 3)))
    out = {}
    for name, fmt, kwargs in [
        ("png", "PNG", {}),
        ("jpeg", "JPEG", {"quality": 90}),
        ("jpeg-progressive", "JPEG", {"quality": 90, "progressive": True}),
        ("jpeg-exif", "JPEG", {"quality": 90, "exif": exif_bytes()}),
    ]:
        buffer = io.BytesIO()
        img.save(buffer, fmt, **kwargs)
        out[name] = buffer.getvalue()
    # Stray bytes after the APP0 segment, which libjpeg skips with a warning.
    jpeg = out["jpeg"]
    app0_end = 4 + int.from_bytes(jpeg[4:6], "big")
    out["jpeg-stray-bytes"] = jpeg[:app0_end] + b"\x00\x42\x00" + jpeg[app0_end:]
    return out


def exif_bytes():
    exif = Image.Exif()
    exif[0x010F] = "camera"
    return exif.tobytes()


def png_claiming(width, height):
    """A 3x2 grayscale PNG whose IHDR claims width x height (with its CRC mended)."""
    buffer = io.BytesIO()
    Image.new("L", (3, 2)).save(buffer, "PNG")
    png = bytearray(buffer.getvalue())
    png[16:24] = width.to_bytes(4, "big") + height.to_bytes(4, "big")
    png[29:33] = zlib.crc32(bytes(png[12:29])).to_bytes(4, "big")
    return bytes(png)


def pillow_refuses_size(data):
    """Whether Pillow's Image.open refuses the picture for its size alone."""
    try:
        with warnings.catch_warnings():
            warnings.simplefilter("ignore", Image.DecompressionBombWarning)
            with Image.open(io.BytesIO(data)):
                return False
    except Image.DecompressionBombError:
        return True
    except Exception:
        return False


def ask_ours(xtask, data, path):
    """`xtask chat --image` on the picture, against a closed port: the finished process."""
    with open(path, "wb") as f:
        f.write(data)
    return subprocess.run(
        [xtask, "chat", "--model", "openai:http://127.0.0.1:9/v1", "--prompt", "x", "--image", path,
         "--retries", "0", "--timeout", "1"],
        capture_output=True, text=True)


def ours_refusal(xtask, data, path):
    """Our message for a refused picture (exit 2); None when accepted."""
    r = ask_ours(xtask, data, path)
    return r.stderr if r.returncode == 2 else None


def pillow_reads(data):
    try:
        with Image.open(io.BytesIO(data)) as im:
            im.load()
        return True
    except Exception:
        return False


def ours_reads(xtask, data, path):
    r = ask_ours(xtask, data, path)
    if r.returncode == 2:
        return False
    if r.returncode == 3 and "cannot connect" in r.stderr:
        return True
    sys.exit(f"xtask chat: unexpected exit {r.returncode}: {r.stderr.strip()}")


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--xtask", default=os.path.join(os.environ.get("CARGO_TARGET_DIR", "target"), "debug", "xtask"))
    args = parser.parse_args()
    if not os.access(args.xtask, os.X_OK):
        print(f"{args.xtask}: no xtask binary (cargo build -p xtask, or --xtask PATH)", file=sys.stderr)
        sys.exit(2)
    summary = {"cuts": 0, "agree": 0, "tolerated": 0, "sizes": 0, "sizes_agree": 0, "other": 0}
    with tempfile.TemporaryDirectory() as tmp:
        path = os.path.join(tmp, "picture")
        for name, data in pictures().items():
            n = len(data)
            cuts = sorted(set(range(9, min(n, 73))) | set(range(max(9, n - 64), n + 1)) | set(range(9, n, max(1, n // 64))))
            disagreements = []
            for cut in cuts:
                pillow, ours = pillow_reads(data[:cut]), ours_reads(args.xtask, data[:cut], path)
                summary["cuts"] += 1
                if pillow == ours:
                    summary["agree"] += 1
                    continue
                disagreements.append({"cut": cut, "pillow": pillow, "ours": ours})
                tolerated = name == "png" and pillow and not ours and cut >= n - 20
                summary["tolerated" if tolerated else "other"] += 1
            print(f"{name}: {n} bytes, {len(cuts)} cuts, whole file read by both: "
                  f"{pillow_reads(data) and ours_reads(args.xtask, data, path)}; disagreements: {disagreements}")
        # The size limit, from both sides of Pillow's: 13377 x 13378 is past it, 13377 x 13377 not.
        limit = 2 * Image.MAX_IMAGE_PIXELS
        for width, height in [(13377, 13378), (13377, 13377)]:
            data = png_claiming(width, height)
            over = width * height > limit
            pillow = pillow_refuses_size(data)
            refusal = ours_refusal(args.xtask, data, path)
            by_size = refusal is not None and "pixels, more than" in refusal
            agree = pillow == over and by_size == over and refusal is not None
            summary["sizes"] += 1
            summary["sizes_agree" if agree else "other"] += 1
            print(f"png claiming {width}x{height} ({width * height} pixels, Pillow's limit {limit}): "
                  f"Pillow refuses it by size: {pillow}; ours refuses it: {refusal is not None}, "
                  f"by size: {by_size}")
    print(json.dumps(summary))
    sys.exit(1 if summary["other"] else 0)


if __name__ == "__main__":
    main()
