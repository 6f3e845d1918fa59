"""The version-keyed cache of mtmetrology.web.lab, the cached tables of the machine page and
what several server processes (``mtm serve --workers``) share."""

from __future__ import annotations

import json
import threading

from lxml import html
from webtools import MACHINE, calibration, csrf_of

from mtmetrology.history import add_result, open_history
from mtmetrology.history.amendments import amend_run
from mtmetrology.history.settings import set_machine_limit
from mtmetrology.web.lab import Lab


def test_the_version_follows_data_changes_not_logins(sqlite_lab):
    engine = sqlite_lab.engine
    view = Lab(engine, version_seconds=0)
    before = view.version()
    admin = sqlite_lab.client("admin")  # a login: one audit row
    admin.post("/tokens", data={"csrf": csrf_of(admin, "/tokens"), "name": "t"})
    assert sqlite_lab.audit_count() >= 2
    assert view.version() == before  # the charts stay cached
    versions = [before]
    set_machine_limit(engine, MACHINE.name, "E_X0C", 3.0, 0.9, by="test")
    versions.append(view.version())
    amend_run(engine, 1, {"operator": "ada"}, reason="r", by="test")
    versions.append(view.version())
    add_result(engine, calibration([9.0] * 13), MACHINE, by="test")
    versions.append(view.version())
    assert len(set(versions)) == 4


def test_a_write_of_another_process_shows_at_once_with_version_seconds_0(sqlite_lab):
    per_request = Lab(sqlite_lab.engine, version_seconds=0)
    trusting = Lab(sqlite_lab.engine, version_seconds=3600)
    runs = len(sqlite_lab.runs)
    assert per_request.machine(MACHINE.name).runs == trusting.machine(MACHINE.name).runs == runs
    # another process: its own engine
    add_result(open_history(sqlite_lab.url), calibration([8.0] * 13), MACHINE, by="test")
    assert per_request.machine(MACHINE.name).runs == runs + 1
    assert trusting.machine(MACHINE.name).runs == runs  # until it reads the version again


def _mpe_cell(page: str, parameter: str) -> str:
    rows = html.fromstring(page).xpath('//table[@id="parameters"]/tbody/tr')
    row = next(r for r in rows if r.xpath("td[1]")[0].text_content() == parameter)
    return row.xpath("td[6]")[0].text_content().strip()


def test_the_machine_pages_cached_tables_follow_a_new_mpe(lab):
    admin = lab.client("admin")
    page = admin.get(f"/machines/{MACHINE.name}")
    assert _mpe_cell(page.text, "E_X0C") == ""
    done = admin.post(
        f"/machines/{MACHINE.name}/limits",
        data={"csrf": csrf_of(admin), "parameter": "E_X0C", "mpe": "5", "reliability": "0.9"},
    )
    assert done.status_code == 303
    page = admin.get(f"/machines/{MACHINE.name}", params={"parameter": "E_A0C", "page": 1})
    assert _mpe_cell(page.text, "E_X0C") == "5.0 (0.9)"
    assert _mpe_cell(page.text, "E_A0C") == ""


def test_concurrent_processes_make_one_session_secret(tmp_path):
    from mtmetrology.web.app import _secret

    url = f"sqlite:///{tmp_path / 'history.sqlite'}"
    secrets: list[str] = []
    start = threading.Barrier(8)

    def worker():
        start.wait()
        secrets.append(_secret(url))

    threads = [threading.Thread(target=worker) for _ in range(8)]
    for t in threads:
        t.start()
    for t in threads:
        t.join()
    assert len(secrets) == 8 and len(set(secrets)) == 1 and len(secrets[0]) >= 48
    assert [p.name for p in tmp_path.iterdir()] == ["web-secret"]
    assert (tmp_path / "web-secret").stat().st_mode & 0o777 == 0o600


def test_a_worker_serves_the_environments_history_and_reads_the_version_per_request(
    sqlite_lab, monkeypatch
):
    from mtmetrology.web.app import worker_app

    monkeypatch.setenv("MTMETROLOGY_DB", sqlite_lab.url)
    monkeypatch.setenv("MTMETROLOGY_WEB_SECRET", "w" * 40)
    app = worker_app()
    assert str(app.state.engine.url) == sqlite_lab.url
    assert app.state.lab.version_seconds == 0
    assert app.state.lab.machine(MACHINE.name).runs == len(sqlite_lab.runs)


def test_concurrent_requests_compute_a_cached_value_once(sqlite_lab):
    view = Lab(sqlite_lab.engine)
    calls: list[int] = []
    start = threading.Barrier(8)

    def slow():
        calls.append(1)
        threading.Event().wait(0.2)  # long enough for every thread to ask meanwhile
        return len(calls)

    results: list[int] = []

    def reader():
        start.wait()
        results.append(view.cached(("slow",), slow))

    threads = [threading.Thread(target=reader) for _ in range(8)]
    for t in threads:
        t.start()
    for t in threads:
        t.join()
    assert calls == [1] and results == [1] * 8


def test_a_reading_request_reads_the_version_once_and_a_write_shows_at_the_next(
    sqlite_lab, monkeypatch
):
    # as mtm serve --workers: version_seconds = 0, so without the per-request snapshot
    # every cached value of a page would read the version again (six for a machine page)
    view = sqlite_lab.app.state.lab
    monkeypatch.setattr(view, "version_seconds", 0)
    reads: list[tuple] = []
    read = view._read_version
    monkeypatch.setattr(view, "_read_version", lambda: reads.append(read()) or reads[-1])
    engineer = sqlite_lab.client("engineer")
    reads.clear()
    assert engineer.get(f"/machines/{MACHINE.name}").status_code == 200
    assert len(reads) == 1
    before = reads[0]
    document = json.dumps(calibration([5.0] * 13)).encode()
    done = engineer.post(
        "/upload",
        data={"csrf": csrf_of(engineer, "/upload"), "note": "n"},
        files={"result": ("cal.json", document, "application/json")},
    )
    assert done.status_code == 303, done.text
    reads.clear()
    assert engineer.get(f"/machines/{MACHINE.name}").status_code == 200
    assert len(reads) == 1 and reads[0] != before
    assert view.machine(MACHINE.name).runs == len(sqlite_lab.runs) + 1
