"""``python -m nsp.app`` as its users meet it: the server on a free port, a real Chromium (Playwright,
driving Debian's ``chromium``) uploading a photo, painting, downloading the SVG; ``gradio_client``
calling ``/paint``; bad uploads; two paintings at once. Skipped, saying why, where Gradio, Playwright
or Chromium is missing (``make setup`` installs the first two, ``.ci/run`` the browser)."""
import os
import shutil
import socket
import subprocess
import sys
import time
import urllib.request
from pathlib import Path

import numpy as np
import pytest
from PIL import Image

from nsp.images import _builtin, load_image, psnr, resize

gradio_client = pytest.importorskip("gradio_client", reason="the app's tests need Gradio: pip install 'nsp[app]'")
CHROMIUM = shutil.which("chromium") or shutil.which("chromium-browser")
SCREENSHOT = os.environ.get("NSP_APP_SCREENSHOT")  # where the browser test also keeps its screenshot (docs/img/app.png)


def free_port() -> int:
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]


@pytest.fixture(scope="module")
def server(tmp_path_factory):
    """The app as a user starts it, on a free port: (url, its log file, its files' folder)."""
    port, log = free_port(), tmp_path_factory.mktemp("app") / "app.log"
    env = os.environ | {"PYTHONUNBUFFERED": "1"}
    with open(log, "w") as out:
        process = subprocess.Popen([sys.executable, "-m", "nsp.app", f"port={port}", "strokes=30", "threads=1"],
                                   stdout=out, stderr=subprocess.STDOUT, env=env)
    url = f"http://127.0.0.1:{port}/"
    deadline = time.monotonic() + 60  # the bound: answering within 60 s
    while True:
        try:
            urllib.request.urlopen(url, timeout=2)
            break
        except OSError:
            assert process.poll() is None and time.monotonic() < deadline, log.read_text()
            time.sleep(0.5)
    folder = Path(log.read_text().split("its files in ")[1].split(";")[0])
    yield url, log, folder
    process.terminate()
    process.wait(30)
    assert not folder.exists()  # the app's files go with it


@pytest.fixture
def browser():
    """A headless Chromium driven by Playwright; skipped, saying why, where either is missing."""
    if CHROMIUM is None:
        pytest.skip("no Chromium here (Debian: apt-get install chromium; .ci/run installs it)")
    playwright = pytest.importorskip("playwright.sync_api", reason="the browser test needs Playwright: pip install playwright")
    with playwright.sync_playwright() as p:
        chromium = p.chromium.launch(executable_path=CHROMIUM, args=["--no-sandbox"])
        yield chromium
        chromium.close()


def client(url):
    return gradio_client.Client(url, verbose=False)


def test_paint_endpoint_paints_the_photo_and_returns_its_files(server):
    url, _, _ = server
    photo = _builtin("astronaut")
    painting, said, files = client(url).predict(gradio_client.handle_file(str(photo)), "watercolor", 200, api_name="/paint")
    score = psnr(resize(load_image(painting), 256), resize(load_image(str(photo)), 256))
    assert score >= 20, score
    assert "200 watercolor strokes, PSNR" in said
    assert {Path(f).name for f in files} == {"final.png", "painting.svg", "strokes.json", "animation.gif"}
    assert Path(next(f for f in files if f.endswith(".svg"))).read_text().startswith("<svg")


@pytest.mark.parametrize("make, says", [
    (lambda path: path.write_text("not a picture"), "photo text.png is not an image this can read"),
    (lambda path: Image.new("1", (30_000, 30_000)).save(path), "photo bomb.png is 30000×30000 pixels, over the limit"),
], ids=["text named .png", "decompression bomb"])
def test_a_bad_upload_gets_one_line_and_the_app_keeps_serving(server, tmp_path, make, says):
    url, _, _ = server
    path = tmp_path / ("text.png" if "text" in says else "bomb.png")
    make(path)
    with pytest.raises(gradio_client.exceptions.AppError) as error:
        client(url).predict(gradio_client.handle_file(str(path)), "tape", 10, api_name="/paint")
    message = str(error.value)
    assert message.startswith(says) and "\n" not in message and "/tmp" not in message, message
    assert urllib.request.urlopen(url, timeout=5).status == 200


def test_an_upload_over_the_limit_is_refused_before_it_is_sent(server, tmp_path):
    url, _, _ = server
    big = tmp_path / "big.png"
    big.write_bytes(os.urandom(50 * 2**20))
    with pytest.raises(ValueError) as refused:
        client(url).predict(gradio_client.handle_file(str(big)), "tape", 10, api_name="/paint")
    assert "exceeds the maximum file size of 20971520 bytes" in str(refused.value)
    assert urllib.request.urlopen(url, timeout=5).status == 200


def test_two_paintings_at_once_both_finish_with_their_own_files(server):
    url, _, folder = server
    jobs = [client(url).submit(gradio_client.handle_file(str(_builtin(name))), "tape", 30, api_name="/paint")
            for name in ("chelsea", "coffee")]
    results = [job.result(timeout=300) for job in jobs]
    strokes = [Path(next(f for f in files if f.endswith("strokes.json"))).read_bytes() for _, _, files in results]
    assert all("30 tape strokes" in said for _, said, _ in results) and strokes[0] != strokes[1]


def test_in_a_browser_upload_paint_watch_and_download_the_svg(server, browser, tmp_path):
    url, _, folder = server
    page = browser.new_page(viewport={"width": 1280, "height": 900}, accept_downloads=True)
    page.goto(url)
    before = set(folder.iterdir())  # other tests' API sessions'
    page.locator("#photo input[type=file]").set_input_files(str(_builtin("chelsea")))
    page.locator("#brush input").click()
    page.get_by_role("option", name="markerpen").click()
    page.locator("#strokes input[type=number]").fill("60")
    page.locator("#strokes input[type=number]").press("Enter")
    page.locator("#paint").click()
    page.locator("#status p", has_text="60 markerpen strokes, PSNR").wait_for(timeout=120_000)
    sessions = [p for p in set(folder.iterdir()) - before if p.is_dir()]
    assert len(sessions) == 1 and (next(sessions[0].iterdir()) / "painting.svg").is_file()  # the session's own folder
    page.locator("#canvas img").wait_for()
    with page.expect_download() as download:
        page.locator("#files a[download='painting.svg']").click()
    svg = tmp_path / "painting.svg"
    download.value.save_as(svg)
    assert svg.read_text().startswith("<svg") and svg.read_text().count("<image") == 60  # each stroke its paint
    shot = tmp_path / "app.png"
    page.screenshot(path=str(shot), full_page=True)
    if SCREENSHOT:
        shutil.copy(shot, SCREENSHOT)
    assert np.asarray(Image.open(shot)).std() > 10  # a page with pictures on it, not a blank one
    page.close()
    deadline = time.monotonic() + 60
    while sessions[0].exists() and time.monotonic() < deadline:  # the session ended: its files go
        time.sleep(1)
    assert not sessions[0].exists()


def test_in_a_browser_stop_keeps_what_was_painted_and_it_re_renders(server, browser, tmp_path):
    url, _, _ = server
    page = browser.new_page()
    page.goto(url)
    big = tmp_path / "big.png"
    big.write_bytes(os.urandom(50 * 2**20))
    page.locator("#photo input[type=file]").set_input_files(str(big))  # refused by Gradio itself, on the page
    page.get_by_text("exceed the maximum allowed size of 20.0 Mb", exact=False).first.wait_for(timeout=30_000)
    page.locator("#builtin input").click()
    page.get_by_role("option", name="coffee").click()
    page.locator("#photo img").wait_for()
    page.locator("#strokes input[type=number]").fill("3000")
    page.locator("#strokes input[type=number]").press("Enter")
    page.locator("#paint").click()
    page.locator("#status p", has_text="strokes placed…").wait_for(timeout=60_000)
    page.locator("#stop").click()
    page.locator("#status p", has_text="stopped:").wait_for(timeout=60_000)
    kept = int(page.locator("#status").inner_text().split("stopped: ")[1].split()[0])
    assert 0 < kept < 3000
    page.locator("#files a[download='strokes.json']").wait_for()
    page.locator("#rerender_size input").fill("300")
    page.locator("#rerender").click()
    page.locator("#rerendered a[download='painting_300px.png']").wait_for(timeout=60_000)
