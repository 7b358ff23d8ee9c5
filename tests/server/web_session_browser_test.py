#!/usr/bin/python3
"""The session page in a real browser at 1366x768 (docs/web.md, "Session
series"): headless Chromium driven by Selenium against a real ves-server on
loopback. A session uploaded now has its series computed in the background,
so its page shows its plots on the first load without asking twice; Play
moves the replay and the plots' time cursor forward, at the chosen speed; a
lesson session shows the server's verdict (PASSED) and each criterion; three
session pages opened at once on sessions stored before series existed all
load, the one the server is too busy for saying so and asking again by
itself. Screenshots go to --out. Exits 77 (CTest SKIP) with a reason when
Chromium cannot run here.
"""
import argparse
import json
import sqlite3
import subprocess
import sys
import time

from browser_harness import BrowserRun


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument('--server', required=True)
    ap.add_argument('--seed', required=True)
    ap.add_argument('--out', required=True)
    args = ap.parse_args()

    with BrowserRun('ves-web-session-', args.out) as run:
        from selenium.common.exceptions import TimeoutException
        from selenium.webdriver.common.by import By
        from selenium.webdriver.support.ui import Select, WebDriverWait
        db_path = run.path('ves.db')
        db = run.db
        tokens = run.seed(args.seed)
        # Three sessions stored before series existed (none computed).
        old = [json.loads(subprocess.check_output(
            [args.seed, 'store', db, 't1', 'expert', '30'], text=True)) for _ in range(3)]
        run.start_server(args.server)
        grpc_port = run.grpc.split(':')[1]
        base = run.base

        # A session uploaded now: its series is computed in the background.
        fresh = json.loads(subprocess.check_output(
            [args.seed, 'upload', '127.0.0.1:' + grpc_port, tokens['station'], 't1', 'expert',
             '20'], text=True))
        lesson = json.loads(subprocess.check_output(
            [args.seed, 'lesson', '127.0.0.1:' + grpc_port, tokens['supervisor'],
             tokens['station'], 't2'], text=True))
        assert lesson['passed'], lesson

        def stored_series(uuid):
            with sqlite3.connect('file:%s?mode=ro' % db_path, uri=True, timeout=10) as c:
                return c.execute('SELECT count(*) FROM session_series WHERE session_uuid = ?',
                                 (uuid,)).fetchone()[0]

        end = time.time() + 120
        while not (stored_series(fresh['uuid']) and stored_series(lesson['uuid'])):
            assert time.time() < end, 'the background worker computed no series in 120 s'
            time.sleep(0.2)
        assert not any(stored_series(o['uuid']) for o in old)

        driver = run.start_browser('1366,768')
        ready = run.ready
        shot = run.shot

        def scroll_to(element_id):
            driver.execute_script("document.getElementById(arguments[0]).scrollIntoView()",
                                  element_id)

        def cursor_dark_pixels(chart):
            """Dark grey pixels in the 3 columns at the chart's time cursor (the
            dashed line) and in 3 columns 25 px to their left, for comparison."""
            return driver.execute_script(
                "const c = ves.charts[arguments[0]]; const a = c.chartArea;"
                "const ctx = c.canvas.getContext('2d'); const r = devicePixelRatio;"
                "const count = (x) => { const d = ctx.getImageData(Math.round(x * r) - 1,"
                "  Math.round(a.top * r), 3, Math.round((a.bottom - a.top) * r)).data;"
                "  let n = 0; for (let i = 0; i < d.length; i += 4)"
                "    if (d[i + 3] > 100 && d[i] < 140 && Math.abs(d[i] - d[i + 2]) < 20"
                "        && Math.abs(d[i] - d[i + 1]) < 20) n++;"
                "  return n; };"
                "const x = c.scales.x.getPixelForValue(c.$vesCursorT);"
                "return [count(x), count(x - 25)]", chart)

        driver.get(base + '/')
        ready('sign-in')
        # Tokens are under "Sign in with an access token" (people use accounts).
        driver.find_element(By.CSS_SELECTOR, '#token-sign-in summary').click()
        driver.find_element(By.ID, 'token').send_keys(tokens['supervisor'])
        driver.find_element(By.ID, 'sign-in').click()
        WebDriverWait(driver, 30).until(lambda d: d.current_url.endswith('/trainees.html'))
        ready('trainees')

        # First load of a session whose series the worker stored: plots on
        # the first ask, one point per frame, the cursor at the start.
        driver.get(base + '/session.html?uuid=' + fresh['uuid'])
        ready('session')
        attempts = driver.execute_script('return ves.seriesAttempts')
        assert attempts == 1, 'series asked %s times' % attempts
        frames = driver.execute_script('return ves.replay.frames.length')
        lengths = driver.execute_script(
            'return [ves.charts.force, ves.charts.stretch, ves.charts.depth]'
            '.map(c => c.data.datasets[0].data.length)')
        assert frames > 100 and all(n == frames for n in lengths), (frames, lengths)
        plots_ms = driver.execute_script('return ves.timing.plots_ms')
        print('session page: plots drawn %.0f ms after navigation (%d frames)' % (
            plots_ms, frames), flush=True)
        assert plots_ms < 5000, plots_ms
        assert driver.find_element(By.ID, 'fig-t').text == '0.0 s'
        assert not driver.find_element(By.ID, 'verdict').is_displayed()  # a free run
        shot('s01-session-first-load')
        scroll_to('replay')
        shot('s01b-session-plots')

        # Play at 4x: time, scrubber and the plots' cursor move on; Pause stops.
        Select(driver.find_element(By.ID, 'speed')).select_by_value('4')
        play = driver.find_element(By.ID, 'play')
        assert play.text == 'Play'
        scroll_to('replay')
        play.click()
        assert play.text == 'Pause'
        time.sleep(1.5)
        t1 = driver.execute_script('return ves.player.t')
        fig_t = float(driver.find_element(By.ID, 'fig-t').text.split()[0])
        scrub = int(driver.find_element(By.ID, 'scrub').get_attribute('value'))
        cursors = driver.execute_script(
            'return [ves.charts.force, ves.charts.stretch, ves.charts.depth]'
            '.map(c => c.$vesCursorT)')
        assert t1 > 3.0 and fig_t > 2.5 and scrub > 25, (t1, fig_t, scrub)
        assert all(abs(c - cursors[0]) < 1e-9 and c > 2.5 for c in cursors), cursors
        at_cursor, beside = cursor_dark_pixels('depth')
        print('cursor column: %d dark pixels, 25 px left: %d' % (at_cursor, beside), flush=True)
        assert at_cursor > beside + 20, ('no cursor line on the depth plot', at_cursor, beside)
        shot('s02-playing')
        play.click()
        assert play.text == 'Play'
        paused_at = driver.execute_script('return ves.player.t')
        time.sleep(0.5)
        assert driver.execute_script('return ves.player.t') == paused_at
        # A click on a plot moves the cursor there (four fifths of the way).
        scroll_to('plot-depth')
        canvas = driver.find_element(By.ID, 'plot-depth')
        target, x_target = driver.execute_script(
            "const f = ves.replay.frames; const t = f[f.length - 1].t_s * 0.8;"
            "return [t, ves.charts.depth.scales.x.getPixelForValue(t)]")
        from selenium.webdriver.common.action_chains import ActionChains
        ActionChains(driver).move_to_element(canvas).move_by_offset(
            int(round(x_target - canvas.size['width'] / 2)), 0).click().perform()
        # Chart.js handles the click on its next animation frame: wait for it.
        try:
            WebDriverWait(driver, 10).until(
                lambda d: abs(d.execute_script('return ves.player.t') - target) < 0.3)
        except TimeoutException:
            pass  # the assertion below says what the player shows
        picked = driver.execute_script('return ves.player.t')
        assert abs(picked - target) < 0.3, (picked, target)
        assert abs(float(driver.find_element(By.ID, 'fig-t').text.split()[0]) - target) < 0.3
        shot('s03-plot-picked')

        # The lesson session: the server's verdict and each criterion.
        driver.get(base + '/session.html?uuid=' + lesson['uuid'])
        ready('session')
        status = driver.find_element(By.ID, 'verdict-status')
        assert status.is_displayed() and status.text == 'PASSED', status.text
        assert 'passed' in status.get_attribute('class').split()
        checks = driver.find_elements(By.CSS_SELECTOR, '#verdict-checks li')
        texts = [c.text for c in checks]
        assert len(checks) >= 2, texts
        judged = [c for c in checks if c.get_attribute('class') in ('passed', 'failed')]
        assert judged and all(c.get_attribute('class') == 'passed' for c in judged), texts
        assert all(c.text.startswith('✓ passed') for c in judged), texts
        assert any('pain_s' in t for t in texts), texts
        assert 'lesson ' + lesson['lesson_id'] in driver.find_element(By.ID, 'verdict-note').text
        scroll_to('verdict')
        shot('s04-lesson-verdict')

        # Three pages at once on sessions stored before series: the server
        # computes two at a time; the third page says it is busy and asks
        # again by itself, and all three load.
        first = driver.current_window_handle
        for o in old:
            driver.execute_script('window.open(arguments[0])',
                                  base + '/session.html?uuid=' + o['uuid'])
        tabs = [h for h in driver.window_handles if h != first]
        assert len(tabs) == 3
        busy_seen = None
        end = time.time() + 90
        while time.time() < end and busy_seen is None:
            settled = 0
            for h in tabs:
                driver.switch_to.window(h)
                status = driver.find_element(By.ID, 'replay-status')
                if 'busy' in (status.get_attribute('class') or '').split():
                    busy_seen = status.text
                    scroll_to('replay-status')
                    shot('s05-busy-retrying')
                    break
                if driver.execute_script('return document.body.dataset.ready || ""'):
                    settled += 1
            if settled == len(tabs):
                break
        print('busy message: %r' % busy_seen, flush=True)
        assert busy_seen and 'The server is busy' in busy_seen and 'Trying again' in busy_seen, \
            busy_seen
        busy_pages = 0
        for h, o in zip(tabs, old):
            driver.switch_to.window(h)
            ready('session (concurrent)', seconds=120)
            n = driver.execute_script('return ves.replay.frames.length')
            assert n > 250, n
            busy_pages += 1 if driver.execute_script('return ves.seriesBusy || 0') else 0
            assert 'busy' not in (driver.find_element(By.ID, 'replay-status')
                                  .get_attribute('class') or '')
        assert busy_pages >= 1, busy_pages
        shot('s06-third-page-loaded')
        assert all(stored_series(o['uuid']) for o in old), 'computed on view, then stored'
        print('OK: session page (first load, play, cursor, verdict, busy retry)', flush=True)
        return 0


if __name__ == '__main__':
    sys.exit(main())
