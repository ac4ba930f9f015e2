"""What ``zwidth serve`` checks and prepares before uvicorn binds (issue 28).

* **No open default.**  A server bound to anything but loopback without a token lets anyone who can reach the
  port run studies and computations: it refuses to start, saying why and how to make a token, unless the
  operator says so explicitly (``--insecure-no-auth`` or ``ZWIDTH_ALLOW_NO_AUTH=1``).
* **The study store, once, before the workers fork.**  Its path is printed, and it is created and migrated
  here, in the supervisor: ``--workers N`` used to migrate a fresh SQLite file N times at once ("table studies
  already exists").  The default store (under HOME) that cannot be created is refused loudly: exit non-zero
  with the path and the cause.  An explicit ``ZWIDTH_DATABASE_URL`` that does not answer is a loud warning
  only (a database may come up later): the study routes answer 503 and /readyz lists them as degraded.
"""

from __future__ import annotations

import ipaddress
import os

from .settings import Settings, default_database_url, describe_store

__all__ = ["StartRefused", "is_loopback", "check_exposure", "prepare_store", "ALLOW_NO_AUTH_ENV"]

#: Environment variable that allows a non-loopback bind without a token (``1``), as ``--insecure-no-auth`` does.
ALLOW_NO_AUTH_ENV = "ZWIDTH_ALLOW_NO_AUTH"
_MAKE_TOKEN = "python -c 'import secrets; print(secrets.token_urlsafe(32))'"


class StartRefused(Exception):
    """The server must not start; the message says why and what to do."""


def is_loopback(host: str) -> bool:
    """Whether binding ``host`` exposes the server to this machine only (127.0.0.0/8, ::1, localhost)."""
    if host.strip().lower() == "localhost":
        return True
    try:
        return ipaddress.ip_address(host.strip().strip("[]")).is_loopback
    except ValueError:
        return False   # a host name (or "" / "0.0.0.0" / "::"): may be reachable from elsewhere


def check_exposure(host: str, token: str | None, insecure_no_auth: bool = False) -> str | None:
    """None when the bind is safe; a warning to print when it is open by explicit choice; else
    :class:`StartRefused`."""
    if token or is_loopback(host):
        return None
    if insecure_no_auth or os.environ.get(ALLOW_NO_AUTH_ENV) == "1":
        return (f"WARNING: serving on {host} WITHOUT authentication (--insecure-no-auth / {ALLOW_NO_AUTH_ENV}=1): "
                "anyone who can reach this port can run computations and studies")
    raise StartRefused(
        f"refusing to serve on {host} without a token: every /v1 route, study creation included, would be open "
        f"to anyone who can reach the port. Set ZWIDTH_API_TOKEN (or ZWIDTH_API_TOKEN_FILE), e.g. "
        f"`export ZWIDTH_API_TOKEN=$({_MAKE_TOKEN})`; or bind 127.0.0.1; or, knowingly, pass --insecure-no-auth "
        f"(or {ALLOW_NO_AUTH_ENV}=1)")


def prepare_store(settings: Settings) -> tuple[str, str | None]:
    """(the store as printed, a warning or None): the store created and migrated once, here.

    :class:`StartRefused` when the default store (under HOME) cannot be created or migrated."""
    from .studies.store import StudyStore

    url = settings.database_url
    shown = describe_store(url)
    try:
        default = url == default_database_url()
    except ValueError:
        default = False
    try:
        store = StudyStore(url)
        try:
            store.migrate()
        finally:
            store.dispose()
    except Exception as exc:  # noqa: BLE001 - reported, with its cause, to the operator at the terminal
        cause = f"{type(exc).__name__}: {str(exc).splitlines()[0] if str(exc) else ''}"[:300]
        if default:
            raise StartRefused(f"the default study store {shown} cannot be created ({cause}); HOME="
                               f"{os.environ.get('HOME', '<unset>')} must be a writable directory, or set "
                               "ZWIDTH_DATABASE_URL") from None
        return shown, (f"WARNING: the study store {shown} cannot be opened ({cause}); the study routes will "
                       "answer 503 and /readyz lists them as degraded")
    return shown, None
