#!/usr/bin/python3
"""The supervisors' pages in a real browser (docs/web.md): headless Chromium
driven by Selenium against a real ves-server on loopback. Sign in, the
trainee list (a trainee named like markup shows as text), a learning curve
with one point per uploaded session, a session page with its plots, the
replay opening on the colon and the scope's tip and scrubbed to the end
showing the tip at the session's final depth, a lesson's curve after the
server passed it, the sessions' CSV export read with the csv module, the live page, the stations page with the health a headless station reported,
group progress, the audit log (admin: newest first, paged, filtered), sign-out. Screenshots of each page go
to --out. Exits 77 (CTest SKIP) with a reason when Chromium cannot run here.
"""
import argparse
import csv
import io
import json
import os
import subprocess
import sys
import time

from browser_harness import BrowserRun, documented_csv_columns

XSS = '<img src=x onerror=alert(1)>'


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument('--server', required=True)
    ap.add_argument('--seed', required=True)
    ap.add_argument('--station', required=True)
    ap.add_argument('--out', required=True)
    args = ap.parse_args()

    with BrowserRun('ves-web-', args.out) as run:
        from selenium.common.exceptions import NoAlertPresentException
        from selenium.webdriver.common.by import By
        from selenium.webdriver.support.ui import WebDriverWait
        tokens = run.seed(args.seed)
        run.start_server(args.server)
        grpc_port = run.grpc.split(':')[1]
        base = run.base
        work = run.work

        # Three sessions of t1 on the sample case, uploaded as a station does.
        sessions = []
        for operator, seconds in (('novice', '2'), ('expert', '2'), ('expert', '3')):
            sessions.append(json.loads(subprocess.check_output(
                [args.seed, 'upload', '127.0.0.1:' + grpc_port, tokens['station'], 't1',
                 operator, seconds], text=True)))

        driver = run.start_browser('1280,1400')
        ready = run.ready
        shot = run.shot

        def no_alert():
            try:
                driver.switch_to.alert
            except NoAlertPresentException:
                return
            raise AssertionError('a script ran: an alert is open')

        # Sign in.
        driver.get(base + '/')
        ready('sign-in')
        shot('01-sign-in')
        # A supervisor signs in as themselves: a wrong password is refused
        # with the page saying so, then the right one.
        driver.find_element(By.ID, 'username').send_keys(tokens['account'])
        driver.find_element(By.ID, 'password').send_keys('not the password')
        driver.find_element(By.ID, 'password-sign-in').click()
        WebDriverWait(driver, 30).until(lambda d: d.find_element(By.ID, 'error').is_displayed())
        assert 'wrong username or password' in driver.find_element(By.ID, 'error').text
        assert driver.find_element(By.ID, 'password').get_attribute('value') == ''
        assert not driver.find_element(By.ID, 'oidc').is_displayed()  # no provider configured
        shot('01b-sign-in-wrong-password')
        driver.find_element(By.ID, 'password').send_keys(tokens['account_password'])
        driver.find_element(By.ID, 'password-sign-in').click()
        WebDriverWait(driver, 30).until(lambda d: d.current_url.endswith('/trainees.html'))
        ready('trainees')
        cookies = {c['name']: c for c in driver.get_cookies()}
        assert cookies['ves_session']['httpOnly'], cookies
        assert cookies['ves_session'].get('sameSite') == 'Strict', cookies
        assert driver.execute_script('return document.cookie') == '', 'the cookie is readable'

        # Trainees: the markup name is text, no element made of it.
        rows = driver.find_elements(By.CSS_SELECTOR, '#trainees tbody tr')
        names = [r.find_elements(By.TAG_NAME, 'td')[0].text for r in rows]
        assert 't1' in names and XSS in names, names
        assert not driver.find_elements(By.CSS_SELECTOR, 'main img'), 'markup became an element'
        no_alert()
        t1 = [r for r in rows if r.find_elements(By.TAG_NAME, 'td')[0].text == 't1'][0]
        assert t1.find_elements(By.TAG_NAME, 'td')[3].text == '3', t1.text
        shot('02-trainees')

        # Learning curve: one point per uploaded session.
        t1.find_element(By.TAG_NAME, 'a').click()
        ready('trainee')
        points = driver.execute_script(
            "return ves.charts['case:standard-adult'].map(c => c.data.datasets[0].data.length)")
        assert points == [3, 3, 3, 3], points
        scores = driver.execute_script(
            "return ves.charts['case:standard-adult'][0].data.datasets[0].data.map(p => p.y)")
        assert [round(s, 6) for s in scores] == [round(s['score'], 6) for s in sessions], scores
        # Runs of 2-3 s never reach the cecum: no time to plot, a dash in the table.
        times = driver.execute_script(
            "return ves.charts['case:standard-adult'][1].data.datasets[0].data.map(p => p.y)")
        assert times == [None, None, None], times
        cells = [r.find_elements(By.TAG_NAME, 'td')[2].text for r in driver.find_elements(
            By.CSS_SELECTOR, '#curve-case-standard-adult table.points tbody tr')]
        assert cells == ['\u2014'] * 3, cells
        assert len(driver.find_elements(By.CSS_SELECTOR, '#sessions tbody tr')) == 3
        shot('03-learning-curve')

        # The CSV export behind the page's link, fetched as the browser would
        # (cookie), read with Python's csv module: the documented columns and
        # one row per session, the same uuids and scores.
        def fetch_text(href):
            return driver.execute_async_script(
                'const done = arguments[arguments.length - 1];'
                'fetch(arguments[0], {credentials: "same-origin"})'
                '.then(r => r.text().then(t => done([r.status, r.headers.get("content-type"), t])))'
                '.catch(e => done([0, "", String(e)]));', href)

        href = driver.find_element(By.ID, 'export-csv').get_attribute('href')
        assert href == base + '/api/v1/trainees/t1/sessions.csv', href
        status, content_type, text = fetch_text(href)
        assert status == 200 and content_type == 'text/csv; charset=utf-8', (status, content_type)
        table = list(csv.reader(io.StringIO(text, newline='')))
        assert table[0] == documented_csv_columns(), (table[0], documented_csv_columns())
        rows = [dict(zip(table[0], r)) for r in table[1:]]
        assert [r['session_uuid'] for r in rows] == [s['uuid'] for s in sessions], rows
        assert all(len(r) == len(table[0]) for r in table), table
        assert [round(float(r['score']), 2) for r in rows] == \
            [round(s['score'], 2) for s in sessions], rows
        assert all(r['trainee_id'] == 't1' and r['case_id'] == 'standard-adult' for r in rows)
        # Days chosen on the page narrow the link: none of these sessions is
        # from 2100, all of them from today or yesterday (UTC).
        driver.execute_script(
            "const f = document.getElementById('export-from'); f.value = '2100-01-01';"
            "f.dispatchEvent(new Event('change'));")
        href = driver.find_element(By.ID, 'export-csv').get_attribute('href')
        assert 'from_unix_ms=4102444800000' in href, href
        status, _, text = fetch_text(href)
        assert status == 200 and len(list(csv.reader(io.StringIO(text, newline='')))) == 1, text
        yesterday = time.strftime('%Y-%m-%d', time.gmtime(time.time() - 86400))
        driver.execute_script(
            "const f = document.getElementById('export-from'); f.value = arguments[0];"
            "f.dispatchEvent(new Event('change'));"
            "const t = document.getElementById('export-to'); t.value = arguments[1];"
            "t.dispatchEvent(new Event('change'));",
            yesterday, time.strftime('%Y-%m-%d', time.gmtime()))
        status, _, text = fetch_text(driver.find_element(By.ID, 'export-csv').get_attribute('href'))
        assert status == 200 and len(list(csv.reader(io.StringIO(text, newline='')))) == 4, text

        # A lesson t2 passes (judged by the server): its curve appears on
        # t2's page with one point per chart and the lesson's pass line.
        lesson = json.loads(subprocess.check_output(
            [args.seed, 'lesson', '127.0.0.1:' + grpc_port, tokens['supervisor'],
             tokens['station'], 't2'], text=True))
        assert lesson['passed'], lesson
        driver.get(base + '/trainee.html?id=t2')
        ready('trainee')
        key = 'lesson:' + lesson['lesson_id']
        points = driver.execute_script(
            'return (ves.charts[arguments[0]] || []).map(c => c.data.datasets[0].data.length)', key)
        assert points == [1, 1, 1, 1], (key, points)
        score = driver.execute_script('return ves.charts[arguments[0]][0].data.datasets[0].data[0].y',
                                      key)
        assert round(score, 6) == round(lesson['score'], 6), (score, lesson)
        pain_sets = driver.execute_script(
            'return ves.charts[arguments[0]][2].data.datasets.map(d => d.label)', key)
        # Then the scripted expert's band (web_cohort_browser_test reads it).
        assert pain_sets[:2] == ['Pain', 'pass line'], pain_sets
        block = driver.find_element(By.ID, 'curve-' + key.replace(':', '-'))
        assert block.find_element(By.TAG_NAME, 'h3').text == 'Lesson ' + lesson['lesson_id']
        assert len(block.find_elements(By.CSS_SELECTOR, 'table.points tbody tr')) == 1
        shot('03b-lesson-curve')

        # The XSS trainee's page shows the name as text too.
        driver.get(base + '/trainee.html?id=' + '%3Cimg%20src%3Dx%20onerror%3Dalert(1)%3E')
        ready('trainee')
        assert driver.find_element(By.ID, 'trainee-id').text == XSS
        no_alert()

        # A session: summary, plots, replay scrubbed to the end.
        last = sessions[-1]
        driver.get(base + '/session.html?uuid=' + last['uuid'])
        ready('session')
        lengths = driver.execute_script(
            'return [ves.charts.force, ves.charts.stretch, ves.charts.depth]'
            '.map(c => c.data.datasets[0].data.length)')
        frames = driver.execute_script('return ves.replay.frames.length')
        assert all(n == frames and n > 10 for n in lengths), (lengths, frames)
        # The replay opens on its first step with the colon and the scope's
        # tip drawn, not on an empty view (all background, #8a8a8a).
        assert driver.find_element(By.ID, 'scrub').get_attribute('value') == '0'
        assert driver.find_element(By.ID, 'fig-t').text == '0.0 s'
        drawn, tip = driver.execute_script(
            "const c = document.getElementById('fluoro');"
            "const d = c.getContext('2d').getImageData(0, 0, c.width, c.height).data;"
            "let drawn = 0, tip = 0; for (let i = 0; i < d.length; i += 4) {"
            "  if (d[i] !== 0x8a || d[i + 1] !== 0x8a || d[i + 2] !== 0x8a) drawn++;"
            "  if (d[i] > 200 && d[i + 1] > 160 && d[i + 2] < 140) tip++; }"
            "return [drawn, tip]")
        assert drawn > 1000 and tip > 5, 'the replay at t = 0: %d pixels drawn, %d of the tip' % (
            drawn, tip)
        shot('04-session')
        driver.execute_script(
            "const s = document.getElementById('scrub'); s.value = s.max;"
            "s.dispatchEvent(new Event('input'));")
        depth = driver.find_element(By.ID, 'tip-depth').text
        expected = '%.0f mm' % (last['final_tip_arc_m'] * 1000)
        assert depth == expected, 'tip at the end: %s, the session ended at %s' % (depth, expected)
        shot('05-replay-end')

        # Live: a headless `ves-station run` paced to the wall clock streams
        # its session; the live page lists it and draws the tip moving.
        station_log = open(os.path.join(args.out, 'ves-station.log'), 'w')
        station = subprocess.Popen(
            [args.station, 'run', '--trainee', 't1', '--case', 'standard-adult',
             '--server', '127.0.0.1:' + grpc_port, '--token', tokens['station'],
             '--headless', '--operator', 'expert', '--out', os.path.join(work, 'station-out'),
             '--data-dir', os.path.join(work, 'station-data'), '--seconds', '12', '--realtime',
             '--frame-every-s', '100', '--station-id', 'browser-station'],
            stdout=station_log, stderr=subprocess.STDOUT)
        try:
            driver.get(base + '/live.html')
            ready('live')
            WebDriverWait(driver, 60).until(lambda d: any(
                r.find_elements(By.TAG_NAME, 'td')[0].text == 't1'
                for r in d.find_elements(By.CSS_SELECTOR, '#live-list tbody tr')))
            row = driver.find_elements(By.CSS_SELECTOR, '#live-list tbody tr')[0]
            assert 'standard-adult' in row.text, row.text
            shot('06-live-list')
            row.find_element(By.TAG_NAME, 'a').click()
            ready('live')
            WebDriverWait(driver, 30).until(lambda d: d.execute_script(
                'const t = ves.live.tips; return t.length >= 10 && t[t.length - 1] > t[0] + 0.005'))
            tips = driver.execute_script('return ves.live.tips')
            assert tips[-1] > tips[0], 'the tip did not move: %s' % tips
            assert driver.find_element(By.ID, 'live-tip-depth').text.endswith(' mm')
            with open(os.path.join(args.out, 'ves-station.log')) as f:
                renders = 'the views cannot render here' not in f.read()
            if renders:  # the station sends endoscope JPEGs when it can render them
                WebDriverWait(driver, 30).until(lambda d: d.execute_script(
                    "const i = document.getElementById('live-jpeg');"
                    "return !i.hidden && i.complete && i.naturalWidth === 320"))
            shot('07-live-session')
            assert station.wait(120) == 0, 'ves-station run failed (ves-station.log)'
        finally:
            if station.poll() is None:
                station.kill()
                station.wait()
        station_log.close()
        with open(os.path.join(args.out, 'ves-station.log')) as f:
            log = f.read()
        assert ' frames streamed' in log and 'live: 0 frames' not in log, log[-2000:]

        # Stations: the headless station above reported its health with its
        # upload; the seeded uploads (web_seed) carried none.
        version = subprocess.check_output([args.station, '--version'], text=True).split()[-1]
        faulty_session = json.loads(subprocess.check_output(
            [args.seed, 'upload', '127.0.0.1:' + grpc_port, tokens['station'],
             't2', 'novice', '1', 'ward-3', 'faulty'], text=True))
        driver.get(base + '/stations.html')
        ready('stations')
        rows = {r.get_attribute('data-station'): [td.text for td in r.find_elements(By.TAG_NAME, 'td')]
                for r in driver.find_elements(By.CSS_SELECTOR, '#stations tbody tr')}
        assert set(rows) == {'browser-station', 'web-test-station', 'ward-3'}, rows
        cells = rows['browser-station']
        assert cells[0] == 'browser-station' and cells[1].endswith(' UTC'), cells
        assert cells[2] == version, (cells, version)
        assert cells[3] == 'sim', cells
        # Headless runs on simulated time: no loop timing, no overrun count.
        assert cells[4] == 'not timed (simulated time) / 1000 \u00b5s', cells
        assert cells[5] == '\u2014', cells
        safe_state = int(cells[6].split()[0])
        can_errors = int(cells[7].split()[0])
        flagged = [td.get_attribute('class') == 'flagged' for td in driver.find_elements(
            By.CSS_SELECTOR, '#stations tbody tr[data-station="browser-station"] td')]
        # A cell is flagged exactly when its count is not zero.
        assert flagged == [False] * 6 + [safe_state > 0, can_errors > 0], (flagged, cells)
        seeded = rows['web-test-station']
        assert seeded[2] == version and seeded[3] == 'not reported', seeded
        # A station whose health is out of range everywhere: every health cell flagged.
        faulty = rows['ward-3']
        assert faulty[3:] == ['can:can0', '1500 / 1000 \u00b5s', '12 of 2000',
                              '1 (1 re-armed, 0 paused)',
                              '2 (bus 2, lost 0, unsent 0, malformed 0)'], faulty
        ward = driver.find_element(By.CSS_SELECTOR, '#stations tbody tr[data-station="ward-3"]')
        assert 'unhealthy' in ward.get_attribute('class').split(), ward.get_attribute('class')
        flagged = [td.get_attribute('class') == 'flagged'
                   for td in ward.find_elements(By.TAG_NAME, 'td')]
        assert flagged == [False] * 4 + [True] * 4, flagged
        shot('08-stations')

        # The same health on that session's page, flagged the same way; a
        # session whose station reported none says so.
        driver.get(base + '/session.html?uuid=' + faulty_session['uuid'])
        ready('session')
        dds = driver.find_elements(By.CSS_SELECTOR, '#health dd')
        assert [d.text for d in dds] == [version, 'can:can0', '1500 / 1000 \u00b5s', '12 of 2000',
                                         '1 (1 re-armed, 0 paused)',
                                         '2 (bus 2, lost 0, unsent 0, malformed 0)'], \
            [d.text for d in dds]
        assert [d.get_attribute('class') == 'flagged' for d in dds] == [False] * 2 + [True] * 4
        shot('08b-session-health')
        driver.get(base + '/session.html?uuid=' + sessions[0]['uuid'])
        ready('session')
        dds = [d.text for d in driver.find_elements(By.CSS_SELECTOR, '#health dd')]
        assert dds[1:] == ['not reported', '\u2014', '\u2014', '\u2014', '\u2014'], dds

        # Group progress.
        driver.get(base + '/progress.html?group=g1')
        ready('progress')
        rows = [r.text for r in driver.find_elements(By.CSS_SELECTOR, '#progress tbody tr')]
        assert len(rows) == 2 and rows[0].startswith('t1') and rows[1].startswith('t2'), rows
        shot('09-progress')

        # Sign out: the pages send us back to sign-in.
        driver.find_element(By.ID, 'sign-out').click()
        WebDriverWait(driver, 30).until(lambda d: d.current_url.endswith('/index.html'))
        driver.get(base + '/trainees.html')
        WebDriverWait(driver, 30).until(lambda d: d.current_url.endswith('/index.html'))

        # The audit log, as an admin.
        ready('sign-in')
        # Tokens are under "Sign in with an access token".
        driver.find_element(By.CSS_SELECTOR, '#token-sign-in summary').click()
        driver.find_element(By.ID, 'token').send_keys(tokens['admin'])
        driver.find_element(By.ID, 'sign-in').click()
        WebDriverWait(driver, 30).until(lambda d: d.current_url.endswith('/trainees.html'))
        ready('trainees')
        # The audit log: newest first, 50 a page, filtered by actor, action
        # and days, what the page shows read back.
        def audit_rows():
            return [[td.text for td in r.find_elements(By.TAG_NAME, 'td')]
                    for r in driver.find_elements(By.CSS_SELECTOR, '#audit tbody tr')]

        # Enough rows for more than one page: 60 trainee listings (audited).
        driver.execute_async_script(
            'const done = arguments[arguments.length - 1];'
            'Promise.all([...Array(60)].map(() => fetch("/api/v1/trainees")))'
            '.then(() => done(true));')
        # Their rows go through the group commit: wait until no more arrive.
        newest = None
        for _ in range(50):
            latest = json.loads(fetch_text('/api/v1/audit?page_size=1')[2])['entries'][0]['id']
            if latest == newest:
                break
            newest = latest
            time.sleep(0.3)
        driver.get(base + '/audit.html')
        ready('audit')
        first = audit_rows()
        ids = [int(r[0]) for r in first]
        assert len(ids) == 50 and ids == sorted(ids, reverse=True), ids
        assert ids[0] == newest, (ids[0], newest)
        shot('10-audit')
        assert driver.find_element(By.ID, 'audit-newer').get_attribute('disabled')
        driver.find_element(By.ID, 'audit-older').click()
        WebDriverWait(driver, 30).until(
            lambda d: d.find_element(By.ID, 'audit').get_attribute('data-page') == '2')
        older = [int(r[0]) for r in audit_rows()]
        assert older and older == sorted(older, reverse=True) and older[0] < ids[-1], (ids, older)
        driver.find_element(By.ID, 'audit-newer').click()
        WebDriverWait(driver, 30).until(
            lambda d: d.find_element(By.ID, 'audit').get_attribute('data-page') == '1')
        assert [int(r[0]) for r in audit_rows()] == ids
        # Filtered through the form: one action of one actor.
        driver.find_element(By.ID, 'filter-actor').send_keys(tokens['account'])
        driver.find_element(By.ID, 'filter-action').send_keys('trainee.curve')
        driver.find_element(By.ID, 'filter-apply').click()
        WebDriverWait(driver, 30).until(lambda d: 'action=trainee.curve' in d.current_url)
        ready('audit')
        rows = audit_rows()
        assert rows and all(r[5] == 'trainee.curve' and r[2] == tokens['account']
                            for r in rows), rows
        assert driver.find_element(By.ID, 'filter-action').get_attribute('value') == 'trainee.curve'
        shot('10b-audit-filtered')
        driver.get(base + '/audit.html?action=session.upload')
        ready('audit')
        uploads = audit_rows()
        # The three seeded uploads, the faulty station's and the live run's.
        assert len(uploads) >= 5 and all(r[5] == 'session.upload' for r in uploads), uploads
        today = time.strftime('%Y-%m-%d', time.gmtime())
        driver.get(base + '/audit.html?action=session.upload&from=' + today + '&to=' + today)
        ready('audit')
        assert audit_rows() == uploads, audit_rows()
        driver.get(base + '/audit.html?action=session.upload&from=2100-01-01')
        ready('audit')
        assert audit_rows() == [] and driver.find_element(By.ID, 'audit-page').text == 'No entries.'
        driver.find_element(By.ID, 'sign-out').click()
        WebDriverWait(driver, 30).until(lambda d: d.current_url.endswith('/index.html'))
        print('web_browser_test: all pages checked; screenshots in ' + args.out)
        return 0


if __name__ == '__main__':
    sys.exit(main())
