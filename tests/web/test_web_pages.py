"""The pages and the API show what the library computes (same calls as ``mtm history``)."""

from __future__ import annotations

import base64
import json
import re
from datetime import timedelta

import numpy as np
from lxml import etree
from webtools import MACHINE, PASSWORD, calibration, csrf_of

from mtmetrology.history import parameter_drift, parameter_trend
from mtmetrology.history.amendments import show_amended
from mtmetrology.history.dcc import validate_certificate
from mtmetrology.history.settings import set_lab_settings, set_machine_limit
from mtmetrology.web.lab import Lab


def _api(lab, role="viewer"):
    client = lab.client(role)
    page = client.post("/tokens", data={"csrf": csrf_of(client, "/tokens"), "name": "t"})
    secret = re.search(r"(mtm_[\w-]+)", page.text).group(1)
    return client, {"Authorization": f"Bearer {secret}"}


def test_machine_status_and_due_date_from_the_drift_model(lab):
    engine = lab.engine
    view = Lab(engine)
    assert [m.status for m in view.overview()] == ["ok"]  # no MPE: no due date
    # an MPE the drifting E_X0C (0.1 µm per 30 days) reaches: the model's due date
    set_machine_limit(engine, MACHINE.name, "E_X0C", 3.0, 0.9, by="test")
    view.invalidate()  # written here, not through the application: seen within 1 s otherwise
    expected = parameter_drift(engine, MACHINE.name, "E_X0C", mpe=3.0, reliability=0.9)
    m = view.machine(MACHINE.name)
    assert m.due_date == expected.due_date and m.due_parameter == "E_X0C"
    assert m.reliability == 0.9
    after = expected.due_date + timedelta(days=1)
    assert view.overview(now=after)[0].status == "overdue"
    set_lab_settings(engine, {"due_soon_days": 3650}, by="test")
    view.invalidate()
    before = expected.last_date
    assert before < expected.due_date
    assert view.overview(now=before)[0].status == "due soon"
    set_lab_settings(engine, {"due_soon_days": 0}, by="test")
    view.invalidate()
    assert view.overview(now=before)[0].status == "ok"


def test_machine_page_and_api_show_the_library_trend(lab):
    client, headers = _api(lab)
    trend = parameter_trend(lab.engine, MACHINE.name, "E_X0C")
    page = client.get(f"/machines/{MACHINE.name}", params={"parameter": "E_X0C"})
    assert page.status_code == 200
    assert f"{trend.centre:.4f}" in page.text and f"{trend.upper_limit:.4f}" in page.text
    svg = client.get(f"/machines/{MACHINE.name}/trend.svg", params={"parameter": "E_X0C"})
    assert svg.headers["content-type"].startswith("image/svg+xml")
    assert etree.fromstring(svg.content).tag.endswith("svg")
    api = client.get(
        f"/api/v1/machines/{MACHINE.name}/trend", params={"parameter": "E_X0C"}, headers=headers
    )
    doc = api.json()
    assert doc["centre"] == trend.centre and doc["upper_limit"] == trend.upper_limit
    assert [r["value"] for r in doc["runs"]] == trend.values.tolist()
    machines = client.get("/api/v1/machines", headers=headers).json()
    assert [m["name"] for m in machines] == [MACHINE.name]
    assert machines[0]["calibrations"] == len(lab.runs)
    schema = client.get("/api/v1/openapi.json", headers=headers).json()
    assert "/api/v1/machines/{name}/trend" in schema["paths"]


def test_run_page_report_json_and_validated_certificate(lab):
    client = lab.client("viewer")
    run = client.get("/runs/calibration/2")
    assert 'id="report"' in run.text and "/runs/calibration/2/report.html" in run.text
    report = client.get("/runs/calibration/2/report.html")
    assert report.status_code == 200 and "<svg" in report.text
    result = client.get("/runs/calibration/2/result.json")
    assert result.headers["content-disposition"] == 'attachment; filename="calibration-2.json"'
    record, _ = show_amended(lab.engine, 2)
    assert result.json() == record.result
    # no laboratory set: the certificate is refused with the reason
    refused = client.get("/runs/calibration/2/certificate.xml")
    assert refused.status_code == 400 and "laboratory" in refused.text
    identity = {"laboratory": "Lab", "email": "lab@example.org", "country": "DE"}
    set_lab_settings(lab.engine, identity, by="t")
    # who signs and the machine's maker are stated on a DCC too (issue 32)
    refused = client.get("/runs/calibration/2/certificate.xml")
    assert refused.status_code == 400 and "responsible person" in refused.text
    set_lab_settings(
        lab.engine, {"responsible_person": "A. Person", "manufacturer": "Maker"}, by="t"
    )
    xml = client.get("/runs/calibration/2/certificate.xml")
    assert xml.status_code == 200
    validate_certificate(etree.ElementTree(etree.fromstring(xml.content)))


def test_upload_by_role(lab):
    document = json.dumps(calibration([5.0] * 13)).encode()
    files = {"result": ("cal.json", document, "application/json")}
    viewer = lab.client("viewer")
    refused = viewer.post("/upload", data={"csrf": csrf_of(viewer, "/machines")}, files=files)
    assert refused.status_code == 403
    assert viewer.get("/upload").status_code == 403
    engineer = lab.client("engineer")
    csrf = csrf_of(engineer, "/upload")
    done = engineer.post("/upload", data={"csrf": csrf, "note": "uploaded"}, files=files)
    assert done.status_code == 303 and done.headers["location"] == "/runs/calibration/7"
    again = engineer.post("/upload", data={"csrf": csrf}, files=files)
    assert again.status_code == 400 and "already recorded as calibration run 7" in again.text
    # a machine new to the history: administrators only
    three = _three_axis()
    other = calibration(np.full(three.n_params, 0.1), machine=three, model=three.model_name)
    new = {"result": ("m.json", json.dumps(other).encode(), "application/json")}
    assert engineer.post("/upload", data={"csrf": csrf}, files=new).status_code == 403
    admin = lab.client("admin")
    made = admin.post("/upload", data={"csrf": csrf_of(admin, "/upload")}, files=new)
    assert made.status_code == 303, made.text
    # the same validation as mtm history add: not a result, a machine that is a file path
    for bad in ({"kind": "nonsense", "machine": MACHINE.name}, {"machine": "/etc/passwd"}):
        body = {"result": ("x.json", json.dumps(bad).encode(), "application/json")}
        assert (
            admin.post("/upload", data={"csrf": csrf_of(admin, "/upload")}, files=body).status_code
            == 400
        )


def _three_axis():
    from mtmetrology.kinematics.machine import Machine

    return Machine.load("three-axis-xfyz")


def test_api_upload_and_amendment_as_the_command_line(lab):
    client, headers = _api(lab, "engineer")
    content = base64.b64encode(json.dumps(calibration([6.0] * 13)).encode()).decode()
    made = client.post(
        "/api/v1/runs",
        headers=headers,
        json={"filename": "c.json", "content_base64": content, "date": "2026-09-01T08:00+02:00"},
    )
    assert made.status_code == 201, made.text
    run = made.json()
    assert run["performed_at"] == "2026-09-01T06:00:00+00:00"
    amended = client.post(
        f"/api/v1/runs/calibration/{run['id']}/amendments",
        headers=headers,
        json={"why": "wrong month", "date": "2026-08-01T06:00+00:00"},
    )
    assert amended.status_code == 201
    shown = client.get(f"/api/v1/runs/calibration/{run['id']}", headers=headers).json()
    assert shown["performed_at"] == "2026-08-01T06:00:00+00:00"
    assert shown["amendments"][0]["old_value"] == "2026-09-01T06:00:00+00:00"
    _, viewer = _api(lab, "viewer")
    assert (
        client.post(
            "/api/v1/runs", headers=viewer, json={"filename": "c", "content_base64": content}
        ).status_code
        == 403
    )


def test_a_disabled_user_loses_the_session(sqlite_lab):
    engineer = sqlite_lab.client("engineer")
    admin = sqlite_lab.client("admin")
    uid = sqlite_lab.users["engineer"]
    response = admin.post(
        f"/users/{uid}", data={"csrf": csrf_of(admin, "/users"), "role": "engineer", "active": "no"}
    )
    assert response.status_code == 303
    assert engineer.get("/machines").status_code == 303
    from webtools import login

    assert login(sqlite_lab.client(), "engineer", PASSWORD).status_code == 401
