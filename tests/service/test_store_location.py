"""Where studies are stored by default: the user data directory (platformdirs), never the working directory;
and the store's URL is printed with its password hidden."""

from __future__ import annotations

from pathlib import Path

from platformdirs import user_data_path
from sqlalchemy.engine import make_url

from service.settings import Settings, default_database_url, describe_store


def test_default_store_is_in_the_user_data_directory(monkeypatch, tmp_path):
    monkeypatch.delenv("ZWIDTH_DATABASE_URL", raising=False)
    monkeypatch.chdir(tmp_path)
    url = make_url(Settings().database_url)
    assert url.get_backend_name() == "sqlite"
    path = Path(url.database)
    assert path.parent == user_data_path("zwidth", appauthor=False)
    assert not path.is_relative_to(tmp_path)
    assert Settings().database_url == default_database_url()


def test_the_environment_still_chooses_the_store(monkeypatch, tmp_path):
    monkeypatch.setenv("ZWIDTH_DATABASE_URL", f"sqlite:///{tmp_path / 'lab.db'}")
    assert Settings().database_url.endswith("lab.db")


def test_printed_store_hides_the_password():
    shown = describe_store("postgresql+psycopg://zwidth:s3cret@db.lab:5432/zwidth")
    assert "s3cret" not in shown and "db.lab" in shown
    assert describe_store("not a url ::") == "<unparsable database URL>"
