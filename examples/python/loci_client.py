#!/usr/bin/env python3
"""Minimal loci Query client in Python (grpcio), showing Ask and FindObjects.

    python3 loci_client.py ask "where is the book on the table" [--server 127.0.0.1:50051]
    python3 loci_client.py find --class cup --class book [--near X Y Z --radius R] [--limit N]
    python3 loci_client.py selftest        # generate the stubs and check the messages, no server

The Python stubs are generated on first use from proto/loci/v1/*.proto with protoc and
grpc_python_plugin (Debian: protobuf-compiler, protobuf-compiler-grpc, python3-grpcio,
python3-protobuf) into $LOCI_PY_GEN or a per-user cache folder.
Positions are in the map frame, metres.
"""
import argparse
import importlib
import os
import shutil
import subprocess
import sys
import tempfile

HERE = os.path.dirname(os.path.abspath(__file__))
PROTO_ROOT = os.path.normpath(os.path.join(HERE, "..", "..", "proto"))
PROTOS = ["loci/v1/types.proto", "loci/v1/mapping.proto", "loci/v1/query.proto"]


def load_stubs():
    """Imports (generating when needed) query_pb2 and query_pb2_grpc."""
    gen = os.environ.get("LOCI_PY_GEN") or os.path.join(
        os.environ.get("XDG_CACHE_HOME", os.path.join(tempfile.gettempdir(), f"loci-{os.getuid()}")),
        "loci_py_gen")
    stamp = os.path.join(gen, "loci", "v1", "query_pb2_grpc.py")
    newest = max(os.path.getmtime(os.path.join(PROTO_ROOT, p)) for p in PROTOS)
    if not os.path.exists(stamp) or os.path.getmtime(stamp) < newest:
        plugin = shutil.which("grpc_python_plugin")
        if shutil.which("protoc") is None or plugin is None:
            sys.exit("error: need protoc and grpc_python_plugin "
                     "(apt-get install protobuf-compiler protobuf-compiler-grpc)")
        os.makedirs(gen, exist_ok=True)
        subprocess.run(["protoc", f"--proto_path={PROTO_ROOT}", f"--python_out={gen}",
                        f"--grpc_out={gen}", f"--plugin=protoc-gen-grpc={plugin}", *PROTOS],
                       check=True)
        for d in ("loci", os.path.join("loci", "v1")):
            open(os.path.join(gen, d, "__init__.py"), "a").close()
    if gen not in sys.path:
        sys.path.insert(0, gen)
    return (importlib.import_module("loci.v1.query_pb2"),
            importlib.import_module("loci.v1.query_pb2_grpc"))


def fmt_object(o):
    c = o.centroid_m
    robots = ", ".join(o.robots) or "-"
    return (f"#{o.id} {o.class_name} ({o.confidence:.2f}) at ({c.x:.2f}, {c.y:.2f}, {c.z:.2f}) m, "
            f"seen by {robots}")


def ask(stub, pb, args):
    import grpc
    try:
        resp = stub.Ask(pb.AskRequest(text=args.question, robot_name=args.robot or ""),
                        timeout=args.timeout)
    except grpc.RpcError as e:
        if e.code() != grpc.StatusCode.INVALID_ARGUMENT:
            raise
        print(f"[{e.code().name}] {e.details()}")  # a question the server cannot take
        return 1
    print(resp.answer)
    print(f"intent {resp.intent}, count {resp.count}")
    for o in resp.objects:
        print("  " + fmt_object(o))
    for r in resp.relations:
        print(f"  #{r.subject_id} {r.name} #{r.anchor_id} ({r.confidence:.2f}): {r.evidence}")
    return 0


def find(stub, pb, args):
    req = pb.FindObjectsRequest(classes=args.cls or [], min_confidence=args.min_confidence,
                                limit=args.limit)
    if args.near:
        req.near_center_m.x, req.near_center_m.y, req.near_center_m.z = args.near
        req.radius_m = args.radius
    resp = stub.FindObjects(req, timeout=args.timeout)
    print(f"{len(resp.objects)} objects")
    for o in resp.objects:
        print("  " + fmt_object(o))
    return 0


def selftest(pb, pb_grpc):
    """Checks the generated code without a server: messages round-trip, the stub has the rpcs."""
    req = pb.FindObjectsRequest(classes=["cup"], min_confidence=0.5, radius_m=1.5, limit=3)
    req.near_center_m.x = 1.0
    back = pb.FindObjectsRequest.FromString(req.SerializeToString())
    assert back.classes == ["cup"] and back.near_center_m.x == 1.0 and back.limit == 3
    ask_req = pb.AskRequest.FromString(pb.AskRequest(text="what is on the desk").SerializeToString())
    assert ask_req.text == "what is on the desk"
    for rpc in ("Ask", "FindObjects", "GetObject", "WatchObjects", "GetStats"):
        assert hasattr(pb_grpc.QueryStub, "__init__") and rpc in dir(pb_grpc.QueryServicer), rpc
    print("selftest ok")
    return 0


def open_channel(grpc, args):
    """A channel with the bearer token on every call (metadata) and TLS when --tls-ca is given."""
    if args.tls_ca:
        with open(args.tls_ca, "rb") as f:
            channel = grpc.secure_channel(args.server, grpc.ssl_channel_credentials(f.read()))
    else:
        channel = grpc.insecure_channel(args.server)
    if not args.token:
        return channel
    header = ("authorization", "Bearer " + args.token)

    class Bearer(grpc.UnaryUnaryClientInterceptor):
        def intercept_unary_unary(self, continuation, details, request):
            metadata = list(details.metadata or []) + [header]
            details = details._replace(metadata=metadata)
            return continuation(details, request)

    return grpc.intercept_channel(channel, Bearer())


def main():
    p = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawTextHelpFormatter)
    p.add_argument("--server", default="127.0.0.1:50051", help="gRPC address HOST:PORT")
    p.add_argument("--timeout", type=float, default=5.0, help="per-call deadline (s)")
    p.add_argument("--token", default=os.environ.get("LOCI_TOKEN", ""),
                   help="bearer token (default: $LOCI_TOKEN)")
    p.add_argument("--tls-ca", default=os.environ.get("LOCI_TLS_CA", ""),
                   help="CA certificate (PEM) of a TLS server (default: $LOCI_TLS_CA; none: plaintext)")
    sub = p.add_subparsers(dest="cmd", required=True)
    a = sub.add_parser("ask", help="ask an English question")
    a.add_argument("question")
    a.add_argument("--robot", help="viewpoint robot for left/right/front/behind")
    f = sub.add_parser("find", help="structured object search")
    f.add_argument("--class", dest="cls", action="append", help="class name (repeatable)")
    f.add_argument("--min-confidence", type=float, default=0.0)
    f.add_argument("--near", type=float, nargs=3, metavar=("X", "Y", "Z"))
    f.add_argument("--radius", type=float, default=1.0, help="sphere radius with --near (m)")
    f.add_argument("--limit", type=int, default=0)
    sub.add_parser("selftest", help="check the generated stubs, no server needed")
    args = p.parse_args()

    pb, pb_grpc = load_stubs()
    if args.cmd == "selftest":
        return selftest(pb, pb_grpc)
    import grpc  # after the stubs: a missing grpcio gives the clearer error above first
    with open_channel(grpc, args) as channel:
        stub = pb_grpc.QueryStub(channel)
        try:
            return ask(stub, pb, args) if args.cmd == "ask" else find(stub, pb, args)
        except grpc.RpcError as e:
            print(f"error: {args.server}: {e.code().name}: {e.details()}", file=sys.stderr)
            return 2


if __name__ == "__main__":
    sys.exit(main())
