"""The agent's own process: ``python -I -m sdovon_mj.suite.agent_process SOCKET_FD FRAMES_FD``.

Started by `protocol.SealedSession` through the sealing launcher (`landlock.launch`: the file system is sealed
before this interpreter starts, so its ``site`` start-up, ``.pth`` files and ``sitecustomize`` already run sealed),
with two inherited descriptors and nothing else of the evaluator's (no path, no argument, a curated environment, its
scratch folder as HOME, TMPDIR and working directory; its stdout and stderr go to its own log). In order:

1. receive the agent (an `AgentSpec` or a pickled object) with the locations of its top-level modules, load those
   from the locations the evaluator found (their folders are on the allow-list), build it; answer its name and
   declared knowledge;
2. serve the protocol (`protocol.AgentRunner`) until the evaluator closes the socket: messages in (pickled, from
   the trusted evaluator), replies out as JSON, frames read from the shared buffer.
"""

from __future__ import annotations

import sys
import traceback


def _load_top_level(name: str, origin: str, locations: tuple[str, ...]) -> None:
    """Import a top-level module or package from its file, without searching sys.path (sealed folders cannot be listed)."""
    import importlib.util

    if name in sys.modules:
        return
    spec = importlib.util.spec_from_file_location(name, origin, submodule_search_locations=list(locations) or None)
    if spec is None or spec.loader is None:
        raise ImportError(f"cannot load {name} from {origin}")
    module = importlib.util.module_from_spec(spec)
    sys.modules[name] = module
    try:
        spec.loader.exec_module(module)
    except BaseException:
        sys.modules.pop(name, None)
        raise


def serve(sock_fd: int, frames_fd: int) -> int:
    """Run the agent's side of a sealed session; return the exit code."""
    import pickle
    from multiprocessing.connection import Connection

    from .protocol import AgentRunner, AgentSpec, FrameBuffer, build_agent, encode_reply

    conn = Connection(sock_fd)

    def reply(d: dict) -> None:
        conn.send_bytes(encode_reply(d))

    runner = None
    frames = None
    while True:
        try:
            msg = conn.recv()
        except (EOFError, OSError):
            return 0
        kind = msg[0]
        if kind == "close":
            return 0
        try:
            if kind == "agent":
                for name, origin, locations in msg[2]:
                    _load_top_level(name, origin, tuple(locations))
                obj = pickle.loads(msg[1])
                runner = AgentRunner(build_agent(obj) if isinstance(obj, AgentSpec) else obj)
                reply(runner.hello())
                continue
            if runner is None:
                raise RuntimeError(f"protocol message {kind!r} before the agent")
            if kind == "setup":
                sensors = msg[1]
                if frames is not None:
                    frames.close()
                frames = FrameBuffer(sensors.width, sensors.height, frames_fd)
                reply(runner.handle("setup", sensors))
            elif kind in ("begin", "step", "end"):
                head = msg[-1]
                obs = frames.read(head, runner.sensors.depth_min)
                reply(runner.handle(kind, *msg[1:-1], obs))
            else:
                reply(runner.handle(kind, *msg[1:]))
        except Exception:  # the agent's error goes back to the evaluator as text; the session ends there
            reply({"error": traceback.format_exc(limit=20)})


def main(argv: list[str] | None = None) -> int:
    """Entry point of the agent's process."""
    args = sys.argv[1:] if argv is None else argv
    if len(args) != 2:
        print("usage: python -I -m sdovon_mj.suite.agent_process SOCKET_FD FRAMES_FD (started by the evaluator)",
              file=sys.stderr)
        return 2
    return serve(int(args[0]), int(args[1]))


if __name__ == "__main__":
    sys.exit(main())
