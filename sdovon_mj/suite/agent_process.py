"""The agent's own process: ``python -I -m sdovon_mj.suite.agent_process SOCKET_FD FRAMES_FD``.

Started by `protocol.SealedSession` with two inherited descriptors and nothing else of the evaluator's (no path, no
argument, a curated environment, its scratch folder as HOME, TMPDIR and working directory). In order:

1. receive the seal plan and seal the file system (`landlock.restrict`), answering whether it could: before any
   agent code is imported, so a module-level trick runs sealed too;
2. load the agent's top-level module from the location the evaluator found (its folder is on the allow-list), then
   receive the agent (an `AgentSpec` or a pickled object) and build it; answer its name and declared knowledge;
3. serve the protocol (`protocol.AgentRunner`) until the evaluator closes the socket: messages in (pickled, from
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

    from .landlock import Seal, restrict
    from .protocol import AgentRunner, AgentSpec, FrameBuffer, build_agent, encode_reply

    conn = Connection(sock_fd)

    def reply(d: dict) -> None:
        conn.send_bytes(encode_reply(d))

    kind, plan = conn.recv()
    if kind != "seal":
        return 2
    if plan.seal:
        try:
            seal = restrict(list(plan.read), list(plan.write))
        except OSError as e:
            seal = Seal(False, 0, f"Landlock refused the ruleset: {e}")
    else:
        seal = Seal(False, 0, "sealing was switched off")
    reply({"sealed": seal.sealed, "abi": seal.abi, "reason": seal.reason})
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
                for name, origin, locations in plan.modules:
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
