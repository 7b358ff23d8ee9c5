#!/usr/bin/python3
"""Proficiency, the group page and the printable report in a real browser
(docs/web.md, "Proficiency", "Cohorts", "Export"): headless Chromium at
1366x768 driven by Selenium against a real ves-server on loopback. The
trainee list shows curriculum progress and who is proficient; a learning
curve shows the scripted expert's band; the group page shows each trainee's
figures (lesson attempts and practice runs apart), sorts and narrows by day;
its CSV link, fetched with the browser's cookie, reads in Python's csv module
as one row per session; the report page prints to PDF with
`chromium --headless --print-to-pdf`. Screenshots go to --out. Exits 77
(CTest SKIP) with a reason when Chromium cannot run here.
"""
import argparse
import csv
import io
import json
import os
import subprocess
import sys

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
from browser_harness import BrowserRun, documented_csv_columns  # noqa: E402


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument('--server', required=True)
    ap.add_argument('--seed', required=True)
    ap.add_argument('--out', required=True)
    args = ap.parse_args()

    with BrowserRun('ves-web-cohort-', args.out) as run:
        from selenium.webdriver.common.by import By
        from selenium.webdriver.support.ui import Select, WebDriverWait
        chromium = run.chromium
        profile = run.path('profile')
        tokens = run.seed(args.seed)
        run.start_server(args.server)
        grpc = run.grpc
        base = run.base

        # Practice runs (no lesson): t1 a novice's and an expert's, t2 an
        # expert's; then t2 passes the one lesson of "web-lessons", which is
        # assigned to their group g1.
        def upload(trainee, operator, seconds):
            out = subprocess.check_output([args.seed, 'upload', grpc, tokens['station'], trainee,
                                           operator, seconds], text=True)
            return dict(json.loads(out), trainee=trainee, operator=operator, lesson='')
        runs = [upload('t1', 'novice', '2'), upload('t1', 'expert', '2'),
                upload('t2', 'expert', '3')]
        lesson = json.loads(subprocess.check_output(
            [args.seed, 'lesson', grpc, tokens['supervisor'], tokens['station'], 't2'], text=True))
        assert lesson['passed'], lesson
        runs.append(dict(lesson, trainee='t2', operator='expert', lesson=lesson['lesson_id']))
        subprocess.check_call([args.seed, 'assign', grpc, tokens['supervisor'], 'web-lessons',
                               'g1'])
        expert_scores = [r['score'] for r in runs if r['operator'] == 'expert']

        driver = run.start_browser('1366,768', ('--password-store=basic',
                                                '--user-data-dir=' + profile))
        ready = run.ready
        shot = run.shot
        table_rows = run.table_rows


        driver.get(base + '/')
        ready('sign-in')
        # Tokens are under "Sign in with an access token" (people use accounts).
        driver.find_element(By.CSS_SELECTOR, '#token-sign-in summary').click()
        driver.find_element(By.ID, 'token').send_keys(tokens['supervisor'])
        driver.find_element(By.ID, 'sign-in').click()
        WebDriverWait(driver, 30).until(lambda d: d.current_url.endswith('/trainees.html'))
        ready('trainees')

        # The trainee list: progress per curriculum, t2 proficient, t1 not.
        rows = {r['Trainee']: r for r in table_rows('trainees')}
        progress = 'Curricula (lessons passed)'
        assert rows['t1'][progress] == 'Web lessons: 0/1', rows['t1']
        assert rows['t2'][progress] == 'Web lessons: 1/1 proficient', rows['t2']
        badges = driver.find_elements(By.CSS_SELECTOR, '#trainees .badge.proficient')
        assert len(badges) == 1, len(badges)
        assert rows['t1']['Sessions'] == '2' and rows['t2']['Sessions'] == '2', rows
        shot('c01-trainees-progress')

        # t1's curve: the expert band spans the expert runs' scores.
        driver.get(base + '/trainee.html?id=t1')
        ready('trainee')
        band = driver.find_element(By.CSS_SELECTOR, '.expert-band').text
        assert ("the scripted expert's %d run(s)" % len(expert_scores)) in band, band
        assert 'score %.1f–%.1f' % (min(expert_scores), max(expert_scores)) in band, band
        sets = driver.execute_script(
            "const c = Object.entries(ves.charts).find(([k]) => k.startsWith('case:'))[1][0];"
            "return c.data.datasets.map((d) => ({label: d.label, y: d.data.map((p) => p.y)}));")
        labels = [s['label'] for s in sets]
        high = [s for s in sets if s['label'].startswith('expert band')]
        assert high and high[0]['label'] == 'expert band (%d runs)' % len(expert_scores), labels
        assert abs(high[0]['y'][0] - max(expert_scores)) < 1e-9, high
        low = [s for s in sets if s['label'] == 'expert low'][0]
        assert abs(low['y'][0] - min(expert_scores)) < 1e-9, low
        assert driver.find_element(By.ID, 'report-link').get_attribute('href').endswith(
            '/report.html?id=t1')
        shot('c02-curve-expert-band')

        # The group page: lesson attempts first, practice runs apart.
        driver.get(base + '/group.html?group=g1')
        ready('group')
        shown = {r['Trainee']: r for r in table_rows('cohort')}
        assert set(shown) == {'t1', 't2'}, shown
        assert shown['t1']['Attempts'] == '0' and shown['t2']['Attempts'] == '1', shown
        assert shown['t2']['Best score'] == '%.1f' % lesson['score'], shown['t2']
        assert shown['t2']['Lessons passed'] == '1/1' and shown['t2']['Proficient'] == 'Web lessons'
        assert shown['t1']['Lessons passed'] == '0/1' and shown['t1']['Proficient'] == '—'
        shot('c03-group-lessons')
        Select(driver.find_element(By.ID, 'runs')).select_by_value('practice')
        shown = {r['Trainee']: r for r in table_rows('cohort')}
        practice = {t: [r for r in runs if r['trainee'] == t and not r['lesson']]
                    for t in ('t1', 't2')}
        for t in ('t1', 't2'):
            assert shown[t]['Attempts'] == str(len(practice[t])), shown[t]
            assert shown[t]['Best score'] == '%.1f' % max(r['score'] for r in practice[t]), shown[t]
        # Sorting by best score, then the other way.
        header = [b for b in driver.find_elements(By.CSS_SELECTOR, '#cohort th button.sort')
                  if b.text.startswith('Best score')][0]
        header.click()
        ascending = [r['Best score'] for r in table_rows('cohort')]
        assert ascending == sorted(ascending, key=float), ascending
        driver.find_elements(By.CSS_SELECTOR, '#cohort th button.sort')[3].click()
        descending = [r['Best score'] for r in table_rows('cohort')]
        assert descending == sorted(ascending, key=float, reverse=True), descending
        assert driver.find_elements(By.CSS_SELECTOR, '#cohort th')[3].get_attribute(
            'aria-sort') == 'descending'
        shot('c04-group-practice-sorted')

        # The group's CSV with the browser's cookie: one row per session.
        href = driver.find_element(By.ID, 'cohort-csv').get_attribute('href')
        text = driver.execute_async_script(
            "const done = arguments[arguments.length - 1];"
            "fetch(arguments[0], {credentials: 'same-origin'}).then((r) => r.text()).then(done);",
            href)
        reader = csv.reader(io.StringIO(text, newline=''))
        header_row = next(reader)
        assert header_row == documented_csv_columns(), header_row
        exported = [dict(zip(header_row, r)) for r in reader]
        assert sorted(r['session_uuid'] for r in exported) == sorted(r['uuid'] for r in runs), \
            exported
        by_uuid = {r['session_uuid']: r for r in exported}
        assert by_uuid[lesson['uuid']]['lesson_verdict'] == 'passed', by_uuid[lesson['uuid']]
        for r in runs:
            assert abs(float(by_uuid[r['uuid']]['score']) - r['score']) < 0.01, r

        # Days far ahead: nobody has a session there; the CSV link follows.
        driver.execute_script(
            "for (const id of ['cohort-from', 'cohort-to']) {"
            "  const i = document.getElementById(id); i.value = '2100-01-01';"
            "  i.dispatchEvent(new Event('change')); }")
        ready('group (2100)')
        assert all(r['Attempts'] == '0' for r in table_rows('cohort'))
        assert 'from_unix_ms=4102444800000' in driver.find_element(
            By.ID, 'cohort-csv').get_attribute('href')
        shot('c05-group-2100')

        # The printable report of t2, then the same page printed to PDF.
        driver.get(base + '/report.html?id=t2')
        ready('report')
        assert driver.find_element(By.ID, 'report-trainee').text == 't2'
        assert driver.find_element(By.ID, 'report-group').text == 'g1'
        heading = driver.find_element(By.CSS_SELECTOR, '.report-curriculum h3').text
        assert heading == 'Web lessons: 1 of 1 lessons passed — proficient', heading
        sessions = table_rows('report-sessions')
        assert len(sessions) == 2, sessions
        assert sorted(s['Lesson'] for s in sessions) == ['practice', lesson['lesson_id']]
        assert [s['Verdict'] for s in sessions if s['Lesson'] != 'practice'] == ['passed']
        summary = {r['Runs']: r for r in table_rows('report-summary')}
        assert summary['Lesson attempts']['Attempts'] == '1', summary
        assert summary['Practice runs']['Attempts'] == '1', summary
        shot('c06-report')
        # As printed: the print style sheet hides navigation and buttons.
        driver.execute_cdp_cmd('Emulation.setEmulatedMedia', {'media': 'print'})
        assert not driver.find_element(By.TAG_NAME, 'header').is_displayed()
        assert not driver.find_element(By.ID, 'print').is_displayed()
        assert driver.find_element(By.ID, 'report-sessions').is_displayed()
        shot('c07-report-print-media')
        run.quit_browser()  # writes the session cookie to the profile for the CLI run
        driver = None

        pdf = os.path.join(args.out, 'report-t2.pdf')
        if os.path.exists(pdf):
            os.remove(pdf)
        subprocess.run([chromium, '--headless=new', '--no-sandbox', '--disable-gpu',
                        '--disable-dev-shm-usage', '--password-store=basic',
                        '--user-data-dir=' + profile, '--virtual-time-budget=15000',
                        '--no-pdf-header-footer', '--print-to-pdf=' + pdf,
                        base + '/report.html?id=t2'],
                       check=True, timeout=120, stdout=subprocess.DEVNULL,
                       stderr=subprocess.DEVNULL)
        with open(pdf, 'rb') as f:
            data = f.read()
        assert data.startswith(b'%PDF'), data[:16]
        assert len(data) > 5000, len(data)
        # The page printed is t2's report with its data, not the sign-in page
        # a missing cookie would have led to: the report sets the title (the
        # PDF's /Title, UTF-16 hex when not ASCII) only once the API answered.
        title = 'Report of t2'
        utf16 = title.encode('utf-16-be').hex()
        assert (b'(' + title.encode()) in data or utf16.encode() in data.lower(), \
            'the PDF is not t2\'s report: no title %r' % title
        print('ok: trainee list, expert band, group page, CSV (%d rows), report, PDF %d bytes'
              % (len(exported), len(data)))
        return 0


if __name__ == '__main__':
    sys.exit(main())
