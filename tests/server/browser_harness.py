"""What the Chromium tests of the supervisors' pages share (docs/web.md): the
checks that Selenium and Chromium can run here (else exit 77, CTest SKIP, with
the reason), a work directory, a database seeded by web_seed, ves-server on
loopback with its port files, headless Chromium, waiting for a page to be
ready, screenshots, and closing it all in reverse order.

    with BrowserRun('ves-web-', args.out) as run:
        tokens = run.seed(args.seed)
        run.start_server(args.server)
        driver = run.start_browser('1280,1400')
        driver.get(run.base + '/')
        run.ready('sign-in')
"""
import json
import os
import shutil
import subprocess
import sys
import tempfile
import time

SKIP = 77


def skip(why):
    print('SKIP: ' + why, flush=True)
    sys.exit(SKIP)


def wait_file(path, proc, what='ves-server', seconds=30):
    """The text of the file `proc` writes at `path` (a port), once it is there."""
    end = time.time() + seconds
    while time.time() < end:
        if os.path.exists(path):
            return open(path).read().strip()
        if proc.poll() is not None:
            raise RuntimeError('%s exited with %d' % (what, proc.returncode))
        time.sleep(0.05)
    raise RuntimeError('%s did not write %s' % (what, path))


def documented_csv_columns():
    """The column names of docs/web.md's "Export" table, in order."""
    docs = os.path.join(os.path.dirname(os.path.abspath(__file__)), '..', '..', 'docs', 'web.md')
    with open(docs) as f:
        text = f.read()
    section = text.split('\n## Export\n', 1)[1].split('\n## ', 1)[0]
    columns = []
    for line in section.splitlines():
        if not line.startswith('| `'):
            continue
        first_cell = line.split('|')[1]
        columns += [c for c in first_cell.split('`')[1::2]]
    return columns


class BrowserRun:
    """One browser test's run; skips (exit 77) when Selenium or Chromium is missing."""

    def __init__(self, prefix, out):
        try:
            import selenium.webdriver  # noqa: F401
        except ImportError as e:
            skip('python3-selenium is not installed (deploy/install-deps.sh): %s' % e)
        self.chromium = shutil.which('chromium')
        self.driver_path = shutil.which('chromedriver')
        if not self.chromium or not self.driver_path:
            skip('chromium and chromium-driver are not installed (deploy/install-deps.sh)')
        os.makedirs(out, exist_ok=True)
        self.out = out
        self.work = tempfile.mkdtemp(prefix=prefix)
        self.db = 'sqlite:' + os.path.join(self.work, 'ves.db')
        self.procs = []  # stopped in reverse order
        self.driver = None
        self.grpc = None  # "127.0.0.1:PORT"
        self.base = None  # "http://127.0.0.1:PORT"

    def __enter__(self):
        return self

    def __exit__(self, *exc):
        self.close()
        return False

    def path(self, name):
        return os.path.join(self.work, name)

    def seed(self, seed_binary):
        """A fresh database (web_seed setup); the tokens it made, by role."""
        return json.loads(subprocess.check_output([seed_binary, 'setup', self.db], text=True))

    def add_process(self, proc):
        """A process stopped (in reverse order) when the run closes."""
        self.procs.append(proc)
        return proc

    def start_server(self, server_binary, extra_args=(), http_listen='127.0.0.1:0'):
        """ves-server on the run's database, its log in out/ves-server.log."""
        server = self.add_process(subprocess.Popen(
            [server_binary, '--db', self.db, '--insecure-loopback', '--listen', '127.0.0.1:0',
             '--port-file', self.path('grpc.port'), '--http', http_listen,
             '--http-port-file', self.path('http.port'), '--drain-s', '1'] + list(extra_args),
            stdout=open(os.path.join(self.out, 'ves-server.log'), 'w'),
            stderr=subprocess.STDOUT))
        self.grpc = '127.0.0.1:' + wait_file(self.path('grpc.port'), server)
        self.base = 'http://127.0.0.1:' + wait_file(self.path('http.port'), server)
        return server

    def start_browser(self, window_size='1366,768', extra_flags=()):
        """Headless Chromium driven by Selenium; skips when it cannot start here."""
        from selenium import webdriver
        from selenium.common.exceptions import WebDriverException
        from selenium.webdriver.chrome.service import Service
        options = webdriver.ChromeOptions()
        options.binary_location = self.chromium
        for flag in ('--headless=new', '--no-sandbox', '--disable-gpu', '--disable-dev-shm-usage',
                     '--window-size=' + window_size, '--no-first-run',
                     '--disable-extensions') + tuple(extra_flags):
            options.add_argument(flag)
        try:
            self.driver = webdriver.Chrome(service=Service(self.driver_path), options=options)
        except WebDriverException as e:
            skip('headless Chromium cannot start on this machine: %s' % str(e).splitlines()[0])
        self.driver.set_page_load_timeout(60)
        return self.driver

    def ready(self, page, seconds=60):
        """Waits for the page's loader (body data-ready); fails with the page's error."""
        from selenium.webdriver.common.by import By
        from selenium.webdriver.support.ui import WebDriverWait
        body = lambda: self.driver.find_element(By.TAG_NAME, 'body')  # noqa: E731
        WebDriverWait(self.driver, seconds).until(
            lambda d: body().get_attribute('data-ready') in ('true', 'error'))
        state = body().get_attribute('data-ready')
        error = self.driver.find_element(By.ID, 'error').text
        assert state == 'true', '%s page failed: %s' % (page, error)

    def table_rows(self, table_id):
        """The rows of a table as dicts by column heading (sort marks dropped)."""
        from selenium.webdriver.common.by import By
        table = self.driver.find_element(By.ID, table_id)
        head = [th.text.replace(' ▲', '').replace(' ▼', '')
                for th in table.find_elements(By.CSS_SELECTOR, 'thead th')]
        return [dict(zip(head, [td.text for td in tr.find_elements(By.TAG_NAME, 'td')]))
                for tr in table.find_elements(By.CSS_SELECTOR, 'tbody tr')]

    def shot(self, name):
        self.driver.save_screenshot(os.path.join(self.out, name + '.png'))

    def quit_browser(self):
        if self.driver is not None:
            self.driver.quit()
            self.driver = None

    def close(self):
        self.quit_browser()
        for proc in reversed(self.procs):
            proc.terminate()
            try:
                proc.wait(20)
            except subprocess.TimeoutExpired:
                proc.kill()
        self.procs = []
        shutil.rmtree(self.work, ignore_errors=True)
