#!/usr/bin/python3
"""The supervisors' workflow in a real browser (docs/web.md, "Workflow"):
headless Chromium at 1366x768 driven by Selenium against a real ves-server on
loopback. A supervisor adds a trainee, puts them in a new group, assigns a
curriculum to the group (and adds another trainee from the group page), writes
a note on a session and signs it off; each is read back from the page that
shows it (the trainee list, the group page, the session page, the trainee's
list of sessions), refusals are shown in words, and an admin finds every
action on the audit page, newest first and filtered by action. Screenshots go
to --out. Exits 77 (CTest SKIP) with a reason when Chromium cannot run here.
"""
import argparse
import json
import os
import subprocess
import sys
import time

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
from browser_harness import BrowserRun  # noqa: E402


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument('--server', required=True)
    ap.add_argument('--seed', required=True)
    ap.add_argument('--out', required=True)
    args = ap.parse_args()

    with BrowserRun('ves-web-workflow-', args.out) as run:
        from selenium.webdriver.common.by import By
        from selenium.webdriver.support.ui import Select, WebDriverWait
        tokens = run.seed(args.seed)
        run.start_server(args.server)
        grpc = run.grpc
        base = run.base
        # A curriculum to assign ("web-lessons") and t2's session of its lesson.
        lesson = json.loads(subprocess.check_output(
            [args.seed, 'lesson', grpc, tokens['supervisor'], tokens['station'], 't2'], text=True))
        session_uuid = lesson['uuid']

        driver = run.start_browser('1366,768', ('--password-store=basic',
                                                '--user-data-dir=' + run.path('profile')))
        ready = run.ready
        shot = run.shot
        table_rows = run.table_rows

        def submit_and_reload(form_id):
            """Submits a reloading form; waits for the page read again."""
            old = driver.find_element(By.TAG_NAME, 'body')
            driver.find_element(By.CSS_SELECTOR, '#%s button[type=submit]' % form_id).click()
            WebDriverWait(driver, 30).until(
                lambda d: d.find_element(By.TAG_NAME, 'body') != old)
            ready(form_id)

        def done_text():
            return driver.find_element(By.CSS_SELECTOR, '#workflow .workflow-done').text

        def sign_in(token):
            driver.get(base + '/')
            ready('sign-in')
            driver.find_element(By.CSS_SELECTOR, '#token-sign-in summary').click()
            driver.find_element(By.ID, 'token').send_keys(token)
            driver.find_element(By.ID, 'sign-in').click()
            WebDriverWait(driver, 30).until(lambda d: d.current_url.endswith('/trainees.html'))
            ready('trainees')

        sign_in(tokens['supervisor'])
        assert driver.find_element(By.ID, 'workflow').is_displayed()

        # A new trainee, read back from the list after the page reloads.
        driver.find_element(By.ID, 'new-trainee-id').send_keys('w.new')
        driver.find_element(By.ID, 'new-trainee-name').send_keys('Wendy New')
        submit_and_reload('add-trainee')
        assert done_text() == 'Added trainee w.new.', done_text()
        rows = {r['Trainee']: r for r in table_rows('trainees')}
        assert rows['w.new']['Name'] == 'Wendy New', rows.get('w.new')
        # The same id again: the server's refusal, in words, under the form.
        driver.find_element(By.ID, 'new-trainee-id').send_keys('w.new')
        driver.find_element(By.CSS_SELECTOR, '#add-trainee button[type=submit]').click()
        WebDriverWait(driver, 30).until(
            lambda d: d.find_element(By.CSS_SELECTOR, '#workflow .workflow-error').text)
        refusal = driver.find_element(By.CSS_SELECTOR, '#workflow .workflow-error').text
        assert refusal.startswith('ALREADY_EXISTS') and 'w.new' in refusal, refusal

        # A new group: w.new put in it.
        Select(driver.find_element(By.ID, 'group-trainee')).select_by_value('w.new')
        driver.find_element(By.ID, 'group-name-input').send_keys('g-web')
        submit_and_reload('set-group')
        assert done_text() == 'Put w.new in group g-web.', done_text()
        rows = {r['Trainee']: r for r in table_rows('trainees')}
        assert rows['w.new']['Group'] == 'g-web', rows['w.new']
        groups = [a.text for a in driver.find_elements(By.CSS_SELECTOR, '#groups li > a:first-child')]
        assert 'g-web' in groups, groups

        # The curriculum assigned to the group: the trainee's progress shows it.
        Select(driver.find_element(By.ID, 'assign-curriculum')).select_by_value('web-lessons')
        Select(driver.find_element(By.ID, 'assign-kind')).select_by_value('group')
        driver.find_element(By.ID, 'assign-to').send_keys('g-web')
        submit_and_reload('assign')
        assert done_text() == 'Assigned web-lessons to group g-web (1 trainee(s)).', done_text()
        rows = {r['Trainee']: r for r in table_rows('trainees')}
        assert rows['w.new']['Curricula (lessons passed)'] == 'Web lessons: 0/1', rows['w.new']
        shot('w01-trainees-after-workflow')

        # The group page: t1 added to the group there.
        driver.get(base + '/group.html?group=g-web')
        ready('group')
        driver.find_element(By.ID, 'group-add-trainee').send_keys('t1')
        submit_and_reload('group-add')
        assert done_text() == 'Put t1 in group g-web.', done_text()
        members = sorted(r['Trainee'] for r in table_rows('cohort'))
        assert members == ['t1', 'w.new'], members
        # The group's assignment form: t1 gets the curriculum through the group.
        Select(driver.find_element(By.ID, 'group-assign-curriculum')).select_by_value('web-lessons')
        submit_and_reload('group-assign')
        assert done_text() == 'Assigned web-lessons to group g-web (2 trainee(s)).', done_text()
        lessons = {r['Trainee']: r['Lessons passed'] for r in table_rows('cohort')}
        assert lessons == {'t1': '0/1', 'w.new': '0/1'}, lessons
        shot('w02-group-after-add')

        # The session page: a note, a refused over-long note, the sign-off.
        driver.get(base + '/session.html?uuid=' + session_uuid)
        ready('session')
        WebDriverWait(driver, 30).until(
            lambda d: d.find_element(By.ID, 'note-form').is_displayed())
        assert driver.find_element(By.ID, 'sign-off-status').text == 'Not signed off.'
        note = 'Good torque steering.\nNext: less push in the sigmoid <please>.'
        driver.find_element(By.ID, 'note-text').send_keys(note)
        driver.find_element(By.CSS_SELECTOR, '#note-form button[type=submit]').click()
        WebDriverWait(driver, 30).until(
            lambda d: d.find_elements(By.CSS_SELECTOR, '#notes li[data-note]'))
        driver.find_element(By.ID, 'note-text').send_keys('Second note.')
        driver.find_element(By.CSS_SELECTOR, '#note-form button[type=submit]').click()
        WebDriverWait(driver, 30).until(
            lambda d: len(d.find_elements(By.CSS_SELECTOR, '#notes li[data-note]')) == 2)
        notes = driver.find_elements(By.CSS_SELECTOR, '#notes li[data-note]')
        # Oldest first, each with who wrote it and when.
        assert notes[0].find_element(By.CSS_SELECTOR, '.note-text').text == note, notes[0].text
        assert notes[1].find_element(By.CSS_SELECTOR, '.note-text').text == 'Second note.'
        assert notes[0].find_element(By.CSS_SELECTOR, '.note-by').text.startswith(
            'supervisor (web test) · 20'), notes[0].text
        # Past the textarea's maxlength (as a script could send): the server's 400, shown.
        driver.execute_script("document.getElementById('note-text').value = 'x'.repeat(2001);")
        driver.find_element(By.CSS_SELECTOR, '#note-form button[type=submit]').click()
        WebDriverWait(driver, 30).until(
            lambda d: d.find_element(By.CSS_SELECTOR, '#notes-section .workflow-error').text)
        too_long = driver.find_element(By.CSS_SELECTOR, '#notes-section .workflow-error').text
        assert too_long.startswith('INVALID_ARGUMENT: text: 2001 bytes'), too_long
        assert len(driver.find_elements(By.CSS_SELECTOR, '#notes li[data-note]')) == 2
        driver.execute_script("document.getElementById('note-text').value = '';")
        driver.find_element(By.ID, 'sign-off').click()
        WebDriverWait(driver, 10).until(lambda d: d.switch_to.alert)
        driver.switch_to.alert.accept()
        WebDriverWait(driver, 30).until(
            lambda d: d.find_element(By.ID, 'sign-off-status').text.startswith('Signed off'))
        status = driver.find_element(By.ID, 'sign-off-status').text
        assert status.startswith('Signed off by supervisor (web test) on 20'), status
        assert not driver.find_element(By.ID, 'sign-off').is_displayed()
        driver.execute_script('window.scrollTo(0, 0)')
        shot('w03-session-note-sign-off')
        # Read again from the server: both still there after a reload.
        driver.refresh()
        ready('session')
        WebDriverWait(driver, 30).until(
            lambda d: d.find_elements(By.CSS_SELECTOR, '#notes li[data-note]'))
        assert driver.find_element(By.CSS_SELECTOR, '#notes .note-text').text == note
        assert driver.find_element(By.ID, 'sign-off-status').text == status

        # The trainee's list of sessions says who signed it off.
        driver.get(base + '/trainee.html?id=t2')
        ready('trainee')
        sessions = table_rows('sessions')
        signed = [r for r in sessions if r['Signed off'] != '—']
        assert len(signed) == 1, sessions
        assert signed[0]['Signed off'].startswith('supervisor (web test), 20'), signed

        # The admin's audit page: every action, newest first, then filtered.
        driver.find_element(By.ID, 'sign-out').click()
        WebDriverWait(driver, 30).until(lambda d: '/index.html' in d.current_url)
        sign_in(tokens['admin'])

        def audit_rows():
            return [[td.text for td in r.find_elements(By.TAG_NAME, 'td')]
                    for r in driver.find_elements(By.CSS_SELECTOR, '#audit tbody tr')]

        # The sign-off's row goes through the group commit: wait for it.
        for _ in range(50):
            driver.get(base + '/audit.html?action=session.sign_off')
            ready('audit')
            if audit_rows():
                break
            time.sleep(0.2)
        driver.get(base + '/audit.html')
        ready('audit')
        ids = [int(r[0]) for r in audit_rows()]
        assert len(ids) >= 20 and ids == sorted(ids, reverse=True), ids
        shot('w04-audit')

        def filtered(action):
            """The audit page filtered by `action` through the form."""
            driver.get(base + '/audit.html')
            ready('audit')
            driver.find_element(By.ID, 'filter-action').send_keys(action)
            driver.find_element(By.ID, 'filter-apply').click()
            WebDriverWait(driver, 30).until(lambda d: 'action=' + action in d.current_url)
            ready('audit')
            rows = audit_rows()
            assert rows and all(r[5] == action for r in rows), (action, rows)
            found = [int(r[0]) for r in rows]
            assert found == sorted(found, reverse=True), (action, found)
            return rows

        adds = filtered('trainee.add')
        assert [(r[6], r[7].split(':')[0], r[2]) for r in adds[:2]] == [
            ('w.new', 'ALREADY_EXISTS', 'supervisor (web test)'),
            ('w.new', 'OK', 'supervisor (web test)')], adds
        groups = filtered('trainee.group')
        assert [(r[6], r[7]) for r in groups[:2]] == [('t1', 'OK'), ('w.new', 'OK')], groups
        assigns = filtered('curriculum.assign')
        assert [(r[6], r[7]) for r in assigns[:2]] == [('web-lessons group g-web', 'OK')] * 2, assigns
        notes = filtered('session.note')
        assert [(r[6], r[7]) for r in notes] == [(session_uuid, 'OK')] * 2, notes
        signs = filtered('session.sign_off')
        assert [(r[6], r[7], r[2]) for r in signs] == [
            (session_uuid, 'OK', 'supervisor (web test)')], signs
        # The actions in the order they were taken (ids grow with time).
        taken = [int(adds[1][0]), int(groups[1][0]), int(assigns[1][0]), int(groups[0][0]),
                 int(assigns[0][0]), int(notes[1][0]), int(notes[0][0]), int(signs[0][0])]
        assert taken == sorted(taken), taken
        # The day filter (the form's GET, as an address): today's, and none tomorrow.
        today = time.strftime('%Y-%m-%d', time.gmtime())
        driver.get(base + '/audit.html?action=session.sign_off&from=' + today + '&to=' + today)
        ready('audit')
        assert [r[0] for r in audit_rows()] == [signs[0][0]], audit_rows()
        assert driver.find_element(By.ID, 'filter-from').get_attribute('value') == today
        shot('w05-audit-filtered')
        tomorrow = time.strftime('%Y-%m-%d', time.gmtime(time.time() + 86400))
        driver.get(base + '/audit.html?action=session.sign_off&from=' + tomorrow)
        ready('audit')
        assert audit_rows() == [], audit_rows()
        assert driver.find_element(By.ID, 'audit-page').text == 'No entries.'
        print('workflow browser test: trainee, group, assignment, note, sign-off and audit read '
              'back at 1366x768; screenshots in ' + args.out, flush=True)


if __name__ == '__main__':
    main()
