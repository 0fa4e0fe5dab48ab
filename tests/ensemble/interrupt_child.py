"""Run by test_backends in a subprocess: map a slow task, say READY after 4 results,
wait for SIGINT, and print what was yielded and what Interrupted.done held (JSON)."""
import json
import sys

from observer_cad.ensemble import Backend, Interrupted, map_chunks
from tests.ensemble.tasks import slow

if __name__ == "__main__":
    kind = sys.argv[1]
    yielded, pids = [], set()
    try:
        for chunk, (c, pid) in map_chunks(slow, 0.3, range(400), backend=Backend(kind, 2)):
            assert c == chunk
            yielded.append(chunk)
            pids.add(pid)
            if len(yielded) == 4:
                print("READY", flush=True)
        print(json.dumps({"finished": True}), flush=True)
    except Interrupted as exc:
        assert all(c == r[0] for c, r in exc.done)
        pids |= {r[1] for _, r in exc.done}
        print(json.dumps({"yielded": yielded, "done": [c for c, _ in exc.done],
                          "pids": sorted(pids)}), flush=True)
