"""The service with one extra route that fails unexpectedly, for the live test of the 500 path
(tests/service/test_live_abuse.py): no real route may fail on purpose, so this one stands in for a bug."""

from service.app import create_app

app = create_app()


@app.get("/v1/test-only/boom")
def boom() -> None:
    raise RuntimeError("a bug at /work/secret/path.py")
