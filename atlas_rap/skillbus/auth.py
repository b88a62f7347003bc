"""Who may use a skill host: the bus's secret, the token files that keep it, and the session
keys that authenticate every frame.

Learnt from Jupyter, whose kernels sign every message with HMAC-SHA256 under a
key kept in a connection file only its user can read, and from SROS2 and
Zenoh, which leave transport security (TLS, mutual TLS, ACL) to the
transport's own configuration (``--zenoh-config``, :mod:`~atlas_rap.skillbus.zenoh_bus`).

**The secret.** A skill host (``atlas skills serve``) has a secret of 32
random bytes, kept in a *token file* readable only by its user: JSON such as
``{"robot": "alice", "key": "<64 hex digits>", "signature_scheme":
"hmac-sha256"}``. By default the file is ``<runtime folder>/bus-<robot>.token``
(:func:`default_token_file`), one per robot, so two robots' hosts on one machine
never share or overwrite one. The host makes the secret at its first start and
keeps it, so a host restarted by hand or by a supervisor serves the same
sequencers again; delete the file to make a new one. ``ATLAS_BUS_TOKEN`` (a
secret of at least 16 characters) takes the place of the file on both sides,
for robots provisioned from the environment as containers are.

A sequencer (``atlas run --connect``) takes the secret of each robot from the
token files given (``--token-file``, the robot named inside), else from
``ATLAS_BUS_TOKEN``, else from the robot's default file, so on one machine
``atlas skills serve`` and ``atlas run --connect`` need no option. It reads it
again at every handshake, so a host that comes back with a new secret on the
same machine is met.

**The handshake** (both sides prove they hold the secret; neither sends it):

1. The sequencer's ``Hello`` carries a fresh nonce ``Ns``, and a tag under the
   secret itself.
2. The host answers with a ``Welcome`` carrying its own fresh nonce ``Nh``,
   tagged under the session key ``K = HMAC(secret, "atlas-rap session" |
   session | Ns | Nh)``. The sequencer checks it, so a host without the
   secret cannot pose as one.
3. Every later frame, both ways, is tagged under ``K``.

A tag is HMAC-SHA256 over the direction, the key expression and the payload,
and rides in the Zenoh *attachment* of the put: the payload stays plain JSON
that any client can read. The nonces ride there too: ``tag | nonce`` on the
Hello and the Welcome, ``tag`` elsewhere. A frame whose tag fails is dropped
before it is parsed. Frames are numbered within a session, so a replayed
frame is out of turn and dropped as well; a session of an earlier run
cannot be replayed, since its key depended on the host's nonce of that time.
"""

from __future__ import annotations

import hmac
import json
import os
import secrets
import stat
import tempfile
from collections.abc import Callable, Iterable, Sequence
from dataclasses import dataclass
from pathlib import Path

from atlas_rap.errors import SkillBusError
from atlas_rap.outputs import output_file

TOKEN_ENV = "ATLAS_BUS_TOKEN"
"""The environment variable that holds the bus's secret in place of a token file."""

RUNTIME_ENV = "ATLAS_RUNTIME_DIR"
"""The environment variable that names the runtime folder (default: ``$XDG_RUNTIME_DIR/atlas-rap``)."""

SCHEME = "hmac-sha256"
"""How frames are signed (the token file's ``signature_scheme``, as in Jupyter's connection files)."""

TAG = 32
"""Bytes of a tag (HMAC-SHA256)."""

NONCE = 16
"""Bytes of a handshake nonce."""

KEY_BYTES = 32
"""Bytes of a secret a host makes."""

MIN_SECRET = 16
"""The shortest secret taken from ``ATLAS_BUS_TOKEN``, in characters."""

TO_HOST, TO_SEQUENCER = b">", b"<"
"""The directions a tag covers, so a frame cannot be reflected back to its sender."""


class TokenError(SkillBusError):
    """A token file or secret that cannot be used: missing, unreadable, of another robot, too short."""


@dataclass(frozen=True)
class Secret:
    """The bus's secret for one robot, and where it came from (for messages)."""

    key: bytes
    source: str

    def __repr__(self) -> str:  # never print the key
        return f"Secret(from {self.source})"


# -- where the secret is kept -------------------------------------------------------------


def runtime_dir() -> Path:
    """The folder for token files: ``$ATLAS_RUNTIME_DIR``, else ``$XDG_RUNTIME_DIR/atlas-rap``
    (a per-user folder of the session on systemd machines), else ``~/.local/share/atlas-rap/runtime``
    (as Jupyter falls back)."""
    given = os.environ.get(RUNTIME_ENV)
    if given:
        return Path(given)
    xdg = os.environ.get("XDG_RUNTIME_DIR")
    if xdg:
        return Path(xdg) / "atlas-rap"
    return Path.home() / ".local" / "share" / "atlas-rap" / "runtime"


def default_token_file(robot: str) -> Path:
    """The token file of ``robot``'s skill host on this machine: one per robot."""
    return runtime_dir() / f"bus-{robot}.token"


def secret_from_env() -> Secret | None:
    """The secret in ``ATLAS_BUS_TOKEN``, if it is set."""
    value = os.environ.get(TOKEN_ENV)
    if value is None:
        return None
    if len(value) < MIN_SECRET:
        raise TokenError(f"{TOKEN_ENV} holds {len(value)} characters: a secret needs at least {MIN_SECRET} "
                         f"(make one with: python -c 'import secrets; print(secrets.token_hex(32))')")
    return Secret(value.encode(), TOKEN_ENV)


def read_token_file(path: str | os.PathLike) -> tuple[str, Secret]:
    """The robot a token file is for, and its secret; :class:`TokenError` if it cannot be used."""
    path = Path(path)
    try:
        text = path.read_text(encoding="utf-8")
    except FileNotFoundError:
        raise TokenError(f"token file {path}: no such file") from None
    except (OSError, UnicodeDecodeError) as exc:
        raise TokenError(f"token file {path}: cannot read it ({getattr(exc, 'strerror', None) or exc})") from None
    try:
        data = json.loads(text)
        robot, key, scheme = data["robot"], data["key"], data.get("signature_scheme", SCHEME)
        if type(robot) is not str or type(key) is not str or scheme != SCHEME:
            raise ValueError
        secret = bytes.fromhex(key)
    except (ValueError, KeyError, TypeError, AttributeError):
        raise TokenError(f"token file {path}: not a token file (JSON with 'robot' and 'key' in hex, as "
                         f"atlas skills serve writes it)") from None
    if len(secret) < MIN_SECRET:
        raise TokenError(f"token file {path}: the key is {len(secret)} bytes; it needs at least {MIN_SECRET}")
    return robot, Secret(secret, str(path))


def host_secret(robot: str, path: str | os.PathLike | None = None) -> Secret:
    """The secret a skill host for ``robot`` uses: ``ATLAS_BUS_TOKEN`` if set, else the one in
    ``path`` (default: :func:`default_token_file`), made and written there (readable only by
    this user) if the file does not exist yet."""
    from_env = secret_from_env()
    if from_env is not None:
        return from_env
    path = Path(path) if path is not None else default_token_file(robot)
    if path.exists():
        owner, secret = read_token_file(path)
        if owner != robot:
            raise TokenError(f"token file {path} is robot {owner!r}'s, not {robot!r}'s: give this host a "
                             f"file of its own (--token-file)")
        _check_private(path)
        return secret
    key = secrets.token_bytes(KEY_BYTES)
    _write_private(path, json.dumps({"robot": robot, "key": key.hex(), "signature_scheme": SCHEME}) + "\n")
    return Secret(key, str(path))


def _check_private(path: Path) -> None:
    """A token file others can read, or someone else owns, is not kept secret: refuse it."""
    info = path.stat()
    if info.st_mode & (stat.S_IRWXG | stat.S_IRWXO) or (hasattr(os, "getuid") and info.st_uid != os.getuid()):
        raise TokenError(f"token file {path}: others can read it or it is not yours; make it yours alone "
                         f"(chmod 600 {path}) or delete it so that a new one is made")


def _write_private(path: Path, text: str) -> None:
    """Write ``path`` readable only by this user, whole or not at all (a temporary file renamed).
    The folder is made as every output's is (:func:`atlas_rap.outputs.output_file`), only for
    this user when it is the runtime folder."""
    if path.parent == runtime_dir():
        try:
            path.parent.mkdir(parents=True, exist_ok=True, mode=0o700)
        except OSError:
            pass  # output_file says why
    output_file(path, "token file")
    try:
        handle, temporary = tempfile.mkstemp(dir=path.parent, prefix=f".{path.name}.", suffix=".tmp")
    except OSError as exc:
        raise TokenError(f"token file {path}: cannot write it ({exc.strerror or exc})") from None
    try:
        with os.fdopen(handle, "w", encoding="utf-8") as stream:  # mkstemp makes it 0600
            stream.write(text)
        os.replace(temporary, path)
    except BaseException as exc:
        Path(temporary).unlink(missing_ok=True)
        if isinstance(exc, OSError):
            raise TokenError(f"token file {path}: cannot write it ({exc.strerror or exc})") from None
        raise


SecretSource = Callable[[], Secret]
"""Where a sequencer reads a robot's secret, at each handshake."""


def sequencer_secrets(robots: Sequence[str], token_files: Iterable[str | os.PathLike] = ()) -> dict[str, SecretSource]:
    """For each robot, where its secret is read (module docstring): a token file naming it,
    else ``ATLAS_BUS_TOKEN``, else its default token file. A file given for no robot of
    ``robots`` is an error, as is a robot with two files."""
    given: dict[str, Path] = {}
    for file in token_files:
        robot, _ = read_token_file(file)
        if robot not in robots:
            raise TokenError(f"token file {file} is robot {robot!r}'s; this run uses "
                             f"{', '.join(robots)} (add --robot {robot}, or leave the file out)")
        if robot in given:
            raise TokenError(f"two token files for robot {robot!r}: {given[robot]} and {file}")
        given[robot] = Path(file)

    def source(robot: str) -> SecretSource:
        def read() -> Secret:
            if robot in given:
                return read_token_file(given[robot])[1]
            from_env = secret_from_env()
            if from_env is not None:
                return from_env
            path = default_token_file(robot)
            if not path.exists():
                raise TokenError(f"no token for robot {robot!r}: no {TOKEN_ENV}, and no token file {path} (a skill "
                                 f"host on this machine writes it at start; for a host elsewhere, copy its token "
                                 f"file here and pass --token-file FILE)")
            return read_token_file(path)[1]
        return read

    return {robot: source(robot) for robot in robots}


# -- tags -------------------------------------------------------------------------------------


def new_nonce() -> bytes:
    return secrets.token_bytes(NONCE)


def session_key(secret: Secret, session: str, sequencer_nonce: bytes, host_nonce: bytes) -> bytes:
    """The key of one session: fresh with both sides' nonces (module docstring)."""
    return hmac.digest(secret.key, b"atlas-rap session\0" + session.encode() + b"\0" + sequencer_nonce + host_nonce,
                       "sha256")


def tag(key: bytes, direction: bytes, key_expr: str, payload: bytes, nonce: bytes = b"") -> bytes:
    """HMAC-SHA256 of a frame: its direction, key expression, payload (and a nonce it carries)."""
    expr = key_expr.encode()
    return hmac.digest(key, direction + len(expr).to_bytes(2, "big") + expr + nonce + payload, "sha256")


def verify(key: bytes, direction: bytes, key_expr: str, payload: bytes, attachment: bytes, nonce: bool = False) -> bool:
    """Whether ``attachment`` is a right tag (and nonce, if one is carried) for the frame."""
    if len(attachment) != TAG + (NONCE if nonce else 0):
        return False
    return hmac.compare_digest(attachment[:TAG], tag(key, direction, key_expr, payload, attachment[TAG:]))



__all__ = ["KEY_BYTES", "MIN_SECRET", "NONCE", "RUNTIME_ENV", "SCHEME", "TAG", "TOKEN_ENV", "TO_HOST",
           "TO_SEQUENCER", "Secret", "SecretSource", "TokenError", "default_token_file", "host_secret", "new_nonce",
           "read_token_file", "runtime_dir", "secret_from_env", "sequencer_secrets", "session_key", "tag", "verify"]
