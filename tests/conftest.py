"""Suite-wide guard of the fast local loop (``scripts/test.sh -m "not slow"``, < 2 min on 2 cores).

A test that starts a real server process (marked ``e2e``, or using the live-server fixtures) costs seconds before
it asserts anything; it must be marked ``slow`` too, so that the fast loop never pays for it.  CI runs everything.
"""

from __future__ import annotations

import pytest

#: Fixtures that start a uvicorn process (tests/service/conftest.py, tests/clients/conftest.py).
LIVE_FIXTURES = frozenset({"live_server", "server"})
#: Modules wholly marked slow whose mere collection costs seconds (schemathesis builds a test per operation while
#: collecting): the fast loop does not collect them at all.
SLOW_TO_COLLECT = frozenset({"tests/service/test_fuzz_api.py"})
FAST_LOOP = "not slow"


def pytest_ignore_collect(collection_path, config: pytest.Config) -> bool | None:
    if config.getoption("markexpr", "").strip() == FAST_LOOP and \
            collection_path.as_posix().endswith(tuple(SLOW_TO_COLLECT)):
        return True
    return None


def pytest_collection_modifyitems(config: pytest.Config, items: list[pytest.Item]) -> None:
    unmarked = [item.nodeid for item in items
                if (item.get_closest_marker("e2e") is not None
                    or LIVE_FIXTURES & set(getattr(item, "fixturenames", ())))
                and item.get_closest_marker("slow") is None]
    if unmarked:
        raise pytest.UsageError("tests that start a server process must be marked slow (the fast loop skips them): "
                                + ", ".join(unmarked[:10]) + (" …" if len(unmarked) > 10 else ""))
