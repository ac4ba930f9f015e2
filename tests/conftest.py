"""Suite-wide guard of the fast local loop (``scripts/test.sh -m "not slow"``, < 2 min on 2 cores).

A test that starts a real server process (marked ``e2e``, or using the live-server fixtures) costs seconds before
it asserts anything; it must be marked ``slow`` too, so that the fast loop never pays for it.  CI runs everything.
"""

from __future__ import annotations

import pytest

#: Fixtures that start a uvicorn process (tests/service/conftest.py, tests/clients/conftest.py).
LIVE_FIXTURES = frozenset({"live_server", "server"})


def pytest_collection_modifyitems(config: pytest.Config, items: list[pytest.Item]) -> None:
    unmarked = [item.nodeid for item in items
                if (item.get_closest_marker("e2e") is not None
                    or LIVE_FIXTURES & set(getattr(item, "fixturenames", ())))
                and item.get_closest_marker("slow") is None]
    if unmarked:
        raise pytest.UsageError("tests that start a server process must be marked slow (the fast loop skips them): "
                                + ", ".join(unmarked[:10]) + (" …" if len(unmarked) > 10 else ""))
