"""The Python package as a peer of ``patchvis conformance``: answers the harness's line
protocol (tests/conformance/README.md, "Testing another reader") on stdin and stdout through
``patchvis.Reader``, frustum queries included.

    patchvis conformance --reader 'python3 python/tests/conformance_adapter.py'

(with the wheel installed in that ``python3``). Not a pytest module: test_conformance.py runs it.
"""

import sys

import patchvis


def listed(items):
    return "[" + ",".join(str(int(i)) for i in items) + "]"


def point(text):
    # Python's float() reads the dumps' numbers, inf, -inf and NaN included; the reader
    # rounds them to binary32, which gives the same value as reading binary32 directly.
    return [float(x) for x in text.split(",")]


def main():
    reader = None
    for line in sys.stdin:
        verb, _, rest = line.rstrip("\r\n").partition(" ")
        if verb == "quit":
            break
        if verb == "hello":
            reply = "hello 1 frustum"
        elif verb == "open":
            reader = None
            try:
                reader = patchvis.Reader(rest)
                reply = "ok"
            except patchvis.FormatError as e:
                reply = f"error {e}"
            except OSError as e:
                reply = f"error {rest}: {e}"
        elif reader is None:
            reply = "error no file is open"
        elif verb == "query":
            a = reader.answer(point(rest))
            reply = (
                f"inside {str(a['inside_sphere']).lower()} band {a['band']} "
                f"shells {listed(a['shells'])} views {listed(a['views'])} "
                f"inner {listed(a['inner_views'])} patches {listed(a['patches'])}"
            )
        elif verb == "frustum":
            eye, depth, matrix = rest.split(" ")
            got = reader.query_frustum(point(matrix), depth, eye=point(eye))
            reply = f"patches {listed(got)}"
        else:
            reply = f"error unknown request '{verb}'"
        sys.stdout.write(reply + "\n")
        sys.stdout.flush()


if __name__ == "__main__":
    main()
