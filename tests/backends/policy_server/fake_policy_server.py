#!/usr/bin/env python3
"""A stand-in for openpi's policy server (scripts/serve_policy.py) for the tests of dh_policy_server_client.

Speaks openpi's protocol over a real WebSocket: metadata frame on connect, then one msgpack observation
in, one msgpack action dict out; on an exception the traceback as a text frame and close 1011. openpi's
numpy encoding in msgpack is written out here by hand: an ndarray is the map
    {b"__ndarray__": True, b"data": raw bytes, b"dtype": dtype.str, b"shape": [...]}
with bytes (msgpack bin) marker keys, as openpi_client.msgpack_numpy writes it; a numpy scalar is
{b"__npgeneric__": True, b"data": value, b"dtype": dtype.str}. The observation is checked strictly: the
four LIBERO keys and nothing else, uint8 (224, 224, 3) images, float32 (8,) state, str prompt, ndarray
marker keys as bin (an openpi server would not recognise str ones). A check that fails raises, so the
client sees a server error naming it.

The action chunk answered in mode normal is a deterministic function of the observation, so a test can
check the whole round trip: shape (10, 7),
    actions[i][j] = state[j] + 0.25 * i          for j < 6 (float32 arithmetic)
    actions[i][6] = [prompt_code, image_code, wrist_code, state[6] + state[7], i, i, …][i]
where *_code = (sum of the bytes) % 1000 (prompt as UTF-8); plus "server_timing": {"infer_ms": 12.5}
(a numpy float64 scalar).

Binds 127.0.0.1 on a free port and prints "PORT <n>" on stdout. Runs until stdin closes (the test that
started it ends) or it is killed. Needs python3-websockets 10.x (legacy asyncio API), python3-msgpack,
python3-numpy. `--self-test` checks the encoder and the strict decoder against each other and exits.
"""

import argparse
import asyncio
import os
import sys
import threading
import traceback

import msgpack
import numpy as np
import websockets

MODES = (
    "normal",  # checks the observation, answers the chunk above
    "error",  # every request raises: traceback text frame + close 1011
    "garbage",  # answers a binary frame that is not msgpack
    "no-actions",  # answers {"server_timing": …} without "actions"
    "wrong-shape",  # "actions" of shape (10, 6)
    "wrong-dtype",  # "actions" as int64
    "slow",  # the first request of the process is answered after --delay seconds, later ones at once
    "close-after-metadata",  # sends the metadata, then closes the connection (1000)
    "drop-after-reply",  # answers normally, then closes the connection (the client must reconnect)
    "silent",  # accepts the WebSocket and never sends anything (no metadata)
)

IMAGE_SHAPE = [224, 224, 3]
STATE_DIMS = 8
OBS_KEYS = {"observation/image", "observation/wrist_image", "observation/state", "prompt"}
NDARRAY_KEYS = {b"__ndarray__", b"data", b"dtype", b"shape"}


# --- openpi's numpy encoding, by hand -----------------------------------------------------------------


def encode_numpy(obj):
    """msgpack `default` hook: numpy values as openpi encodes them."""
    if isinstance(obj, (np.ndarray, np.generic)) and obj.dtype.kind in ("V", "O", "c"):
        raise ValueError(f"dtype {obj.dtype} cannot be sent")
    if isinstance(obj, np.ndarray):
        return {b"__ndarray__": True, b"data": obj.tobytes(), b"dtype": obj.dtype.str, b"shape": list(obj.shape)}
    if isinstance(obj, np.generic):
        return {b"__npgeneric__": True, b"data": obj.item(), b"dtype": obj.dtype.str}
    return obj


def pack(obj) -> bytes:
    return msgpack.packb(obj, default=encode_numpy, use_bin_type=True)


def strict_ndarray(value, name):
    """The ndarray `value` decodes to, raising unless it is exactly openpi's map with bin keys."""
    if not isinstance(value, dict):
        raise ValueError(f"{name}: expected an openpi ndarray map, got {type(value).__name__}")
    keys = set(value.keys())
    if keys != NDARRAY_KEYS:
        raise ValueError(f"{name}: ndarray keys must be exactly {sorted(NDARRAY_KEYS)} (msgpack bin), got {sorted(map(repr, keys))}")
    if value[b"__ndarray__"] is not True:
        raise ValueError(f"{name}: __ndarray__ must be true")
    data, dtype, shape = value[b"data"], value[b"dtype"], value[b"shape"]
    if not isinstance(data, bytes):
        raise ValueError(f"{name}: data must be bin, got {type(data).__name__}")
    if not isinstance(dtype, str):
        raise ValueError(f"{name}: dtype must be str, got {type(dtype).__name__}")
    if not isinstance(shape, list) or not all(isinstance(d, int) and d >= 0 for d in shape):
        raise ValueError(f"{name}: shape must be a list of sizes, got {shape!r}")
    dt = np.dtype(dtype)
    if len(data) != int(np.prod(shape, dtype=np.int64)) * dt.itemsize:
        raise ValueError(f"{name}: {len(data)} bytes of data for shape {shape} dtype {dtype}")
    return np.frombuffer(data, dtype=dt).reshape(shape)


def decode_observation(message):
    """The LIBERO observation, checked strictly; raises ValueError naming what is wrong."""
    if not isinstance(message, bytes):
        raise ValueError("the observation must come in a binary frame")
    obs = msgpack.unpackb(message, raw=False)
    if not isinstance(obs, dict):
        raise ValueError(f"the observation must be a map, got {type(obs).__name__}")
    if set(obs.keys()) != OBS_KEYS:
        raise ValueError(f"observation keys must be exactly {sorted(OBS_KEYS)} (msgpack str), got {sorted(map(repr, obs.keys()))}")
    out = {}
    for key in ("observation/image", "observation/wrist_image"):
        image = strict_ndarray(obs[key], key)
        if image.dtype != np.uint8 or list(image.shape) != IMAGE_SHAPE:
            raise ValueError(f"{key}: expected uint8 {IMAGE_SHAPE}, got {image.dtype.str} {list(image.shape)}")
        out[key] = image
    state = strict_ndarray(obs["observation/state"], "observation/state")
    if state.dtype.str != "<f4" or list(state.shape) != [STATE_DIMS]:
        raise ValueError(f"observation/state: expected <f4 [{STATE_DIMS}], got {state.dtype.str} {list(state.shape)}")
    out["observation/state"] = state
    if not isinstance(obs["prompt"], str):
        raise ValueError(f"prompt: expected str, got {type(obs['prompt']).__name__}")
    out["prompt"] = obs["prompt"]
    return out


def action_chunk(obs, dtype):
    state = obs["observation/state"]
    codes = [
        sum(obs["prompt"].encode("utf-8")) % 1000,
        int(obs["observation/image"].sum(dtype=np.uint64) % 1000),
        int(obs["observation/wrist_image"].sum(dtype=np.uint64) % 1000),
    ]
    actions = np.zeros((10, 7), dtype=np.float32)
    for i in range(10):
        actions[i, :6] = state[:6] + np.float32(0.25 * i)
        actions[i, 6] = codes[i] if i < 3 else (state[6] + state[7] if i == 3 else np.float32(i))
    return actions.astype(dtype)


# --- the server ------------------------------------------------------------------------------------


class FakePolicyServer:
    def __init__(self, mode, delay, dtype):
        self.mode, self.delay, self.dtype = mode, delay, dtype
        self.connections = 0
        self.requests = 0

    async def handler(self, ws, path=None):
        self.connections += 1
        connection = self.connections
        if self.mode == "silent":
            await ws.wait_closed()
            return
        await ws.send(pack({"fake": True, "mode": self.mode, "connection": connection, "action_horizon": 10,
                            "policy": "fake pi05_libero"}))
        if self.mode == "close-after-metadata":
            await ws.close(code=1000, reason="fake server: closing after the metadata")
            return
        while True:
            try:
                message = await ws.recv()
            except websockets.ConnectionClosed:
                return
            try:
                obs = decode_observation(message)
                self.requests += 1
                if self.mode == "error":
                    raise RuntimeError("fake policy failure: the model is not loaded")
                if self.mode == "slow" and self.requests == 1:
                    await asyncio.sleep(self.delay)
                if self.mode == "garbage":
                    await ws.send(b"\xc1 this is not msgpack")
                    continue
                timing = {"infer_ms": np.float64(12.5)}
                if self.mode == "no-actions":
                    reply = {"server_timing": timing}
                elif self.mode == "wrong-shape":
                    reply = {"actions": np.zeros((10, 6), dtype=np.float32), "server_timing": timing}
                elif self.mode == "wrong-dtype":
                    reply = {"actions": np.zeros((10, 7), dtype=np.int64), "server_timing": timing}
                else:
                    reply = {"actions": action_chunk(obs, self.dtype), "server_timing": timing}
                await ws.send(pack(reply))
                if self.mode == "drop-after-reply":
                    await ws.close(code=1000, reason="fake server: dropping the connection after a reply")
                    return
            except websockets.ConnectionClosed:
                return
            except Exception:
                # As openpi's server: the traceback as text, then close with INTERNAL_ERROR.
                try:
                    await ws.send(traceback.format_exc())
                    await ws.close(code=1011, reason="Internal server error. Traceback included in previous frame.")
                except websockets.ConnectionClosed:
                    pass
                return


async def serve(args):
    server = FakePolicyServer(args.mode, args.delay, np.float32 if args.dtype == "f4" else np.float64)
    # As openpi: no compression, no size limit.
    ws_server = await websockets.serve(server.handler, "127.0.0.1", args.port, compression=None, max_size=None,
                                       ping_interval=args.ping_interval, ping_timeout=args.ping_interval)
    port = ws_server.sockets[0].getsockname()[1]
    print(f"PORT {port}", flush=True)
    await asyncio.sleep(args.lifetime)


def watch_stdin():
    """Exits when stdin reaches end of file: the process that started this one is gone."""
    try:
        while sys.stdin.buffer.read(4096):
            pass
    finally:
        os._exit(0)


def self_test():
    obs = {
        "observation/image": np.full((224, 224, 3), 7, dtype=np.uint8),
        "observation/wrist_image": np.zeros((224, 224, 3), dtype=np.uint8),
        "observation/state": np.arange(8, dtype=np.float32),
        "prompt": "put the bowl on the plate",
    }
    decoded = decode_observation(pack(obs))
    assert decoded["observation/image"].sum() == 7 * 224 * 224 * 3
    assert decoded["observation/state"][3] == 3.0
    # str marker keys (not openpi's) are refused
    relabelled = dict(obs)
    relabelled["observation/state"] = {"__ndarray__": True, "data": obs["observation/state"].tobytes(),
                                       "dtype": "<f4", "shape": [8]}
    try:
        decode_observation(msgpack.packb(relabelled, default=encode_numpy, use_bin_type=True))
        raise AssertionError("str ndarray keys were accepted")
    except ValueError:
        pass
    # float64 state (openpi's example sends it) is refused by this strict checker
    wrong = dict(obs)
    wrong["observation/state"] = np.arange(8, dtype=np.float64)
    try:
        decode_observation(pack(wrong))
        raise AssertionError("float64 state was accepted")
    except ValueError:
        pass
    chunk = action_chunk(decoded, np.float32)
    assert chunk.shape == (10, 7) and chunk[2, 0] == np.float32(0.5)
    assert chunk[0, 6] == sum(b"put the bowl on the plate") % 1000
    print("self-test passed")


def main():
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--mode", choices=MODES, default="normal")
    parser.add_argument("--port", type=int, default=0, help="0: a free port (printed)")
    parser.add_argument("--delay", type=float, default=6.0, help="seconds the slow mode waits")
    parser.add_argument("--dtype", choices=("f4", "f8"), default="f4", help="dtype of the actions answered")
    parser.add_argument("--ping-interval", type=float, default=20.0,
                        help="keepalive: seconds between pings and to wait for the pong before closing with 1011 "
                             "(websockets' default 20; a client that does not read meanwhile loses its connection)")
    parser.add_argument("--lifetime", type=float, default=600.0, help="seconds before exiting on its own")
    parser.add_argument("--self-test", action="store_true")
    args = parser.parse_args()
    if args.self_test:
        self_test()
        return
    threading.Thread(target=watch_stdin, daemon=True).start()
    asyncio.run(serve(args))


if __name__ == "__main__":
    main()
