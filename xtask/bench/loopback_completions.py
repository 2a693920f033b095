#!/usr/bin/env python3
"""A loopback /v1/completions server for timing the HTTP path of `--lm openai:URL`.

Answers at once with a uniform distribution over the request's `allowed_token_ids` (vLLM
dialect) or over a few fixed ids, named `token_id:N`, so that the client's own cost per
request (connect, send, receive, parse) is what a run measures. HTTP/1.1 with keep-alive.
Counts requests and TCP connections; prints them on SIGINT/SIGTERM or on GET /stats.

    python3 xtask/bench/loopback_completions.py PORT
"""
import json
import math
import signal
import sys
import threading
from http.server import BaseHTTPRequestHandler, ThreadingHTTPServer

STATS = {"requests": 0, "connections": 0}
LOCK = threading.Lock()


class Handler(BaseHTTPRequestHandler):
    protocol_version = "HTTP/1.1"
    # TCP_NODELAY, as model servers (uvicorn under vLLM, llama-server) set it: without it the
    # reply's body waits for the client's delayed ACK of its headers (40 ms) on a kept-alive
    # connection, which would measure Nagle's algorithm instead of the client.
    disable_nagle_algorithm = True

    def setup(self):
        super().setup()
        with LOCK:
            STATS["connections"] += 1

    def log_message(self, *args):
        pass

    def reply(self, body):
        data = json.dumps(body).encode()
        self.send_response(200)
        self.send_header("Content-Type", "application/json")
        self.send_header("Content-Length", str(len(data)))
        self.end_headers()
        self.wfile.write(data)

    def do_GET(self):
        with LOCK:
            self.reply(dict(STATS))

    def do_POST(self):
        length = int(self.headers.get("Content-Length", "0"))
        request = json.loads(self.rfile.read(length))
        with LOCK:
            STATS["requests"] += 1
        allowed = request.get("allowed_token_ids") or [198, 253, 260, 282]
        k = max(1, min(int(request.get("logprobs", 1)), len(allowed)))
        top = {f"token_id:{t}": -math.log(len(allowed)) for t in allowed[:k]}
        self.reply({
            "object": "text_completion",
            "choices": [{"index": 0, "text": "", "finish_reason": "length",
                         "logprobs": {"tokens": [next(iter(top))], "top_logprobs": [top]}}],
            "usage": {"prompt_tokens": len(request.get("prompt", [])), "completion_tokens": 1},
        })


def main():
    server = ThreadingHTTPServer(("127.0.0.1", int(sys.argv[1])), Handler)
    server.daemon_threads = True

    def stop(*_):
        print(json.dumps(STATS), flush=True)
        threading.Thread(target=server.shutdown).start()

    signal.signal(signal.SIGTERM, stop)
    signal.signal(signal.SIGINT, stop)
    server.serve_forever()


if __name__ == "__main__":
    main()
