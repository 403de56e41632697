#!/usr/bin/env python3
"""A scripted OpenAI-compatible chat-completions server for the planner's openai backend tests.

Binds 127.0.0.1 on a free port (or --port), prints the port on stdout, and answers
POST /v1/chat/completions according to --mode:

  valid      an advisory: pick_place bowl -> plate (or the first eligible capability when pick_place
             is not eligible); done=true once the history shows that step completed
  repair     content that is not JSON on the first request, a valid advisory on the repair request
  garbage    content that is never JSON
  schema     JSON content that violates the advisory schema (args a number, "done" missing)
  unknown    a well-formed advisory naming a capability nobody offers ("teleport")
  refuse     the model refuses, with a reason
  http500    HTTP 500 with an OpenAI-style error body
  notjson    HTTP 200 with a body that is not JSON
  sleep      sleeps --sleep-s seconds (longer than the client's timeout), then answers as valid

A request whose user message contains "fake-mode:<mode>" is answered in that mode instead, so one
server can serve several modes at once (it is threaded). With --record FILE every request is appended
to FILE as one JSON line: {"path", "authorization", "body"}. Standard library only; loopback only.
"""

import argparse
import json
import re
import sys
import threading
import time
from http.server import BaseHTTPRequestHandler, ThreadingHTTPServer

MODES = ("valid", "repair", "garbage", "schema", "unknown", "refuse", "http500", "notjson", "sleep")


def user_text(body):
    """The text of the user messages (plain strings or text parts)."""
    out = []
    for m in body.get("messages", []):
        if m.get("role") != "user":
            continue
        c = m.get("content")
        if isinstance(c, str):
            out.append(c)
        elif isinstance(c, list):
            out.extend(p.get("text", "") for p in c if isinstance(p, dict) and p.get("type") == "text")
    return "\n".join(out)


def eligible(body):
    try:
        enum = body["response_format"]["json_schema"]["schema"]["properties"]["capability"]["enum"]
        return [c for c in enum if c]
    except (KeyError, TypeError):
        return []


def valid_advisory(body):
    text = user_text(body)
    if "pick_place completed [object=bowl target=plate]" in text:
        return {"capability": "", "args": {}, "rationale": "the bowl is on the plate", "done": True,
                "refused": False, "reason": "", "rest": []}
    caps = eligible(body)
    cap = "pick_place" if "pick_place" in caps or not caps else caps[0]
    return {"capability": cap, "args": {"object": "bowl", "target": "plate"},
            "rationale": "the instruction asks for the bowl on the plate", "done": False, "refused": False,
            "reason": "", "rest": []}


class Handler(BaseHTTPRequestHandler):
    protocol_version = "HTTP/1.1"

    def log_message(self, fmt, *args):  # keep the test's output clean
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
            pass  # the client gave up (timeout): nothing to do

    def completion(self, body, content):
        return json.dumps({
            "id": "chatcmpl-fake", "object": "chat.completion", "created": 0,
            "model": body.get("model", ""),
            "choices": [{"index": 0, "message": {"role": "assistant", "content": content},
                         "finish_reason": "stop"}],
            "usage": {"prompt_tokens": 0, "completion_tokens": 0, "total_tokens": 0},
        })

    def do_GET(self):
        self.send(404, json.dumps({"error": {"message": "only POST /v1/chat/completions here"}}))

    def do_POST(self):
        length = int(self.headers.get("Content-Length", "0"))
        raw = self.rfile.read(length)
        server = self.server
        try:
            body = json.loads(raw)
        except ValueError:
            body = None
        if server.record:
            with server.lock:
                with open(server.record, "a", encoding="utf-8") as f:
                    f.write(json.dumps({"path": self.path, "authorization": self.headers.get("Authorization"),
                                        "body": body}) + "\n")
        if self.path != "/v1/chat/completions":
            self.send(404, json.dumps({"error": {"message": "no route " + self.path}}))
            return
        if not isinstance(body, dict):
            self.send(400, json.dumps({"error": {"message": "the request body is not a JSON object"}}))
            return
        mode = server.mode
        m = re.search(r"fake-mode:([a-z0-9]+)", user_text(body))
        if m and m.group(1) in MODES:
            mode = m.group(1)
        repair_turn = len(body.get("messages", [])) > 2

        if mode == "http500":
            self.send(500, json.dumps({"error": {"message": "CUDA out of memory (fake)", "code": 500}}))
            return
        if mode == "notjson":
            self.send(200, "<html><body>It works!</body></html>", "text/html")
            return
        if mode == "sleep":
            time.sleep(server.sleep_s)
            mode = "valid"
        if mode == "valid" or (mode == "repair" and repair_turn):
            content = json.dumps(valid_advisory(body))
        elif mode in ("repair", "garbage"):
            content = "Sure! You should put the bowl on the plate."
        elif mode == "schema":
            content = json.dumps({"capability": "pick_place", "args": 42, "rationale": "bad types"})
        elif mode == "unknown":
            content = json.dumps({"capability": "teleport", "args": {"object": "bowl"},
                                  "rationale": "beam it", "done": False, "refused": False})
        else:  # refuse
            content = json.dumps({"capability": "", "args": {}, "rationale": "no capability fits",
                                  "done": False, "refused": True, "reason": "there is no bowl in this scene"})
        self.send(200, self.completion(body, content))


def main():
    p = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("--mode", choices=MODES, default="valid")
    p.add_argument("--port", type=int, default=0)
    p.add_argument("--record", default="")
    p.add_argument("--sleep-s", type=float, default=30.0)
    a = p.parse_args()
    server = ThreadingHTTPServer(("127.0.0.1", a.port), Handler)
    server.daemon_threads = True
    server.mode, server.record, server.sleep_s, server.lock = a.mode, a.record, a.sleep_s, threading.Lock()
    print(server.server_address[1], flush=True)
    try:
        server.serve_forever()
    except KeyboardInterrupt:
        pass
    return 0


if __name__ == "__main__":
    sys.exit(main())
