#!/usr/bin/env python3
"""A scripted SAM-style segmentation server for dh_perception's HttpSegmenter tests.

Binds 127.0.0.1 on a free port, prints the port on stdout, and answers POST /<mode>/segment with the
protocol of services/perception/README.md ("HTTP segmentation protocol"). For prompt i it returns a
rectangle: columns 4+10i .. 9+10i, rows 3 .. 7 of the request's image size. Modes:

  rle        masks as uncompressed COCO RLE (counts arrays), score 0.9 - 0.1 i
  coco       masks as compressed COCO RLE strings
  png        masks as base64 PNGs (8-bit grey, 0/255)
  http500    HTTP 500 with {"error": "model not loaded"}
  notjson    HTTP 200 with an HTML body
  wrongsize  RLE for an image one row taller than the request's (counts consistent with that size)
  pngsize    PNG masks one column wider than the request's image
  badcounts  RLE counts that sum to one pixel less than width*height
  unknown    a mask for a prompt nobody asked ("teapot")
  sleep      sleeps --sleep-s seconds, then answers as rle

A request that breaks the protocol gets HTTP 400 with the reason. With --record FILE every request is
appended to FILE as one JSON line {"path", "body"}. Standard library only; loopback only.
"""

import argparse
import json
import struct
import sys
import time
import zlib
from http.server import BaseHTTPRequestHandler, ThreadingHTTPServer


def rect_mask(width, height, i):
    """Row-major 0/1 list: the rectangle of prompt i."""
    m = [0] * (width * height)
    for y in range(3, 8):
        for x in range(4 + 10 * i, 10 + 10 * i):
            if 0 <= x < width and 0 <= y < height:
                m[y * width + x] = 1
    return m


def rle_counts(mask, width, height):
    """COCO uncompressed RLE: runs in column-major order, starting with background."""
    counts, run, fg = [], 0, 0
    for x in range(width):
        for y in range(height):
            v = mask[y * width + x]
            if v != fg:
                counts.append(run)
                run, fg = 0, v
            run += 1
    counts.append(run)
    return counts


def coco_string(counts):
    """pycocotools' rleToString: differences to the run two before from the fourth run, 5-bit groups."""
    out = []
    for i, c in enumerate(counts):
        x = c - counts[i - 2] if i > 2 else c
        more = True
        while more:
            ch = x & 0x1F
            x >>= 5
            more = (x != -1) if (ch & 0x10) else (x != 0)
            if more:
                ch |= 0x20
            out.append(chr(ch + 48))
    return "".join(out)


def png_grey(mask, width, height):
    def chunk(kind, data):
        return struct.pack(">I", len(data)) + kind + data + struct.pack(">I", zlib.crc32(kind + data))

    raw = b"".join(b"\x00" + bytes(255 * v for v in mask[y * width:(y + 1) * width]) for y in range(height))
    return (b"\x89PNG\r\n\x1a\n" + chunk(b"IHDR", struct.pack(">IIBBBBB", width, height, 8, 0, 0, 0, 0)) +
            chunk(b"IDAT", zlib.compress(raw)) + chunk(b"IEND", b""))


def b64(data):
    import base64
    return base64.b64encode(data).decode()


def check_request(body):
    if body.get("protocol") != "dh-segment/1":
        return "protocol must be dh-segment/1"
    image = body.get("image")
    if not isinstance(image, dict) or image.get("format") != "png" or not isinstance(image.get("data"), str):
        return "image must be {format: png, width, height, data}"
    if not isinstance(image.get("width"), int) or not isinstance(image.get("height"), int):
        return "image width and height must be integers"
    prompts = body.get("prompts")
    if not isinstance(prompts, list) or not all(isinstance(p, str) for p in prompts):
        return "prompts must be a list of strings"
    if body.get("mask_format") not in ("rle", "png"):
        return "mask_format must be rle or png"
    return None


def reply(mode, body):
    w, h = body["image"]["width"], body["image"]["height"]
    prompts = body["prompts"]
    masks = []
    for i, p in enumerate(prompts):
        m = rect_mask(w, h, i)
        entry = {"prompt": p, "score": round(0.9 - 0.1 * i, 3)}
        if mode in ("rle", "sleep"):
            entry["rle"] = {"size": [h, w], "counts": rle_counts(m, w, h)}
        elif mode == "coco":
            entry["rle"] = {"size": [h, w], "counts": coco_string(rle_counts(m, w, h))}
        elif mode == "png":
            entry["png"] = b64(png_grey(m, w, h))
        elif mode == "pngsize":
            entry["png"] = b64(png_grey(rect_mask(w + 1, h, i), w + 1, h))
        elif mode == "wrongsize":
            entry["rle"] = {"size": [h + 1, w], "counts": rle_counts(rect_mask(w, h + 1, i), w, h + 1)}
        elif mode == "badcounts":
            c = rle_counts(m, w, h)
            c[-1] -= 1
            entry["rle"] = {"size": [h, w], "counts": c}
        elif mode == "unknown":
            entry["prompt"] = "teapot"
            entry["rle"] = {"size": [h, w], "counts": rle_counts(m, w, h)}
        masks.append(entry)
    return {"width": w, "height": h, "masks": masks}


class Handler(BaseHTTPRequestHandler):
    protocol_version = "HTTP/1.1"
    record = None
    sleep_s = 5.0

    def log_message(self, fmt, *args):
        pass

    def send(self, status, payload, content_type="application/json"):
        data = payload if isinstance(payload, bytes) else payload.encode()
        try:
            self.send_response(status)
            self.send_header("Content-Type", content_type)
            self.send_header("Content-Length", str(len(data)))
            self.end_headers()
            self.wfile.write(data)
        except (BrokenPipeError, ConnectionResetError):
            pass  # the client gave up (the timeout test)

    def do_POST(self):
        raw = self.rfile.read(int(self.headers.get("Content-Length", "0")))
        parts = self.path.strip("/").split("/")
        if len(parts) != 2 or parts[1] != "segment":
            return self.send(404, json.dumps({"error": "POST /<mode>/segment"}))
        mode = parts[0]
        try:
            body = json.loads(raw)
        except ValueError:
            return self.send(400, json.dumps({"error": "request is not JSON"}))
        if Handler.record:
            with open(Handler.record, "a") as f:
                f.write(json.dumps({"path": self.path, "body": body}) + "\n")
        problem = check_request(body)
        if problem:
            return self.send(400, json.dumps({"error": problem}))
        if mode == "http500":
            return self.send(500, json.dumps({"error": "model not loaded"}))
        if mode == "notjson":
            return self.send(200, "<html><body>busy</body></html>", "text/html")
        if mode == "sleep":
            time.sleep(Handler.sleep_s)
        self.send(200, json.dumps(reply(mode, body)))


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--record")
    ap.add_argument("--sleep-s", type=float, default=5.0)
    args = ap.parse_args()
    Handler.record = args.record
    Handler.sleep_s = args.sleep_s
    server = ThreadingHTTPServer(("127.0.0.1", 0), Handler)
    server.daemon_threads = True
    print(server.server_address[1], flush=True)
    server.serve_forever()


if __name__ == "__main__":
    sys.exit(main())
