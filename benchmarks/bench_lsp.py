"""Benchmark the language server: how soon diagnostics arrive after an edit to a 2,000-line file.

A real LSP client (pytest-lsp's, over stdio, as an editor talks to ``atlas lsp``)
opens a generated mission of about 2,000 lines (the shipped navigation RAPs
copied under new names, with an include and a world), then changes one
character at a time, alternately breaking a call and mending it, and times each
change to the diagnostics it brings. Prints one JSON line:

- ``lsp-diagnostics``: median and worst seconds from an edit to its diagnostics
  (target: <= 0.2 s), and the ratio of the median to the target.

``atlas check``'s cold start (target <= 0.3 s) is ``bench_lang.py``'s ``cold-start``.

Run: ``pip install '.[test]' && python benchmarks/bench_lsp.py`` (``--quick``: fewer edits).
"""

from __future__ import annotations

import argparse
import asyncio
import json
import re
import statistics
import sys
import tempfile
import time
from pathlib import Path

HERE = Path(__file__).resolve().parent
REPO = HERE.parent
TARGET = 0.2


def big_mission(lines: int) -> str:
    """A mission of about ``lines`` lines: the navigation RAPs again and again, each copy's RAPs
    and memory rules (and the calls to them) under names of its own."""
    navigation = (REPO / "rap_library" / "navigation.rap").read_text()
    names = re.findall(r"\(define-rap \(([a-z-]+)", navigation) + re.findall(r"\(define-memory-rule ([a-z-]+)",
                                                                            navigation)
    parts, count = ['(world "lab-corridor-office")\n'], 0
    while sum(part.count("\n") for part in parts) < lines:
        copy = navigation
        for name in names:
            copy = re.sub(rf"([( ]){re.escape(name)}([ )\n])", rf"\g<1>{name}-{count}\g<2>", copy)
        parts.append(copy)
        count += 1
    parts.append("(define-rap (errand) (method (task-net (t1 (go-to-0 office)))))\n(post (errand))\n")
    return "".join(parts)


async def measure(edits: int) -> dict:
    from lsprotocol import types
    from pytest_lsp import ClientServerConfig, client_capabilities

    text = big_mission(2000)
    folder = Path(tempfile.mkdtemp(prefix="bench-lsp-"))
    path = folder / "big.rap"
    path.write_text(text)
    uri = path.as_uri()
    config = ClientServerConfig(server_command=[sys.executable, "-m", "atlas_rap", "lsp"],
                                server_env={"PYTHONPATH": str(REPO), "PATH": "/usr/bin:/bin"})
    client = await config.start()
    try:
        await client.initialize_session(types.InitializeParams(capabilities=client_capabilities("neovim"),
                                                               root_uri=folder.as_uri()))
        client.text_document_did_open(types.DidOpenTextDocumentParams(
            types.TextDocumentItem(uri=uri, language_id="rap", version=1, text=text)))
        await client.wait_for_notification(types.TEXT_DOCUMENT_PUBLISH_DIAGNOSTICS)
        assert not client.diagnostics[uri], client.diagnostics[uri]
        broken = text.replace("(t1 (go-to-0 office))", "(t1 (go-to-x office))")
        times = []
        for version in range(2, edits + 2):
            started = time.perf_counter()
            client.text_document_did_change(types.DidChangeTextDocumentParams(
                types.VersionedTextDocumentIdentifier(uri=uri, version=version),
                [types.TextDocumentContentChangeWholeDocument(text=broken if version % 2 else text)]))
            await client.wait_for_notification(types.TEXT_DOCUMENT_PUBLISH_DIAGNOSTICS)
            times.append(time.perf_counter() - started)
            assert bool(client.diagnostics[uri]) == bool(version % 2)  # broken: one problem; mended: none
        await client.shutdown_session()
    finally:
        await client.stop()
    median = statistics.median(times)
    return {"bench": "lsp-diagnostics", "lines": text.count("\n"), "edits": edits,
            "median_s": round(median, 4), "worst_s": round(max(times), 4), "target_s": TARGET,
            "ratio_to_target": round(median / TARGET, 3)}


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--quick", action="store_true", help="a few edits, to try it out")
    args = parser.parse_args()
    print(json.dumps(asyncio.run(measure(6 if args.quick else 40))), flush=True)


if __name__ == "__main__":
    main()
