#!/usr/bin/python3
"""Sign-in through the hospital's identity provider in a real browser
(docs/web.md, "Signing in through the hospital's identity provider"):
headless Chromium at 1366x768, driven by Selenium, against a real ves-server
configured with --oidc-* for the small local provider oidc_test_idp.py.

A supervisor whose account (ves-admin account create --idp-identity, no
password) names the provider's subject clicks "Sign in with your hospital
account", sees the provider's page, continues, and lands on the trainee list
signed in under their account's name. Then the refusals a person can meet,
each shown on the sign-in page as a sentence and leaving nobody signed in:
the provider's answer with a state that is not the one VES sent, and an ID
token signed by another key. Screenshots go to --out. Exits 77 (CTest SKIP)
with a reason when Chromium, Selenium or python3-cryptography is missing.
"""
import argparse
import json
import os
import socket
import subprocess
import sys
import urllib.parse
import urllib.request

from browser_harness import BrowserRun, skip, wait_file

CLIENT_ID = 'ves-web'
SUBJECT = 'idp-user-1'
ACCOUNT = 'dr.hospital'
IDP_REFUSED = 'The hospital sign-in did not complete. Try again.'  # sign_in.js, kSignInErrors.idp


def free_loopback_port():
    # The provider must know VES's callback address before VES starts (and VES
    # the provider's): a port free now, taken by ves-server a moment later.
    with socket.socket() as s:
        s.bind(('127.0.0.1', 0))
        return s.getsockname()[1]


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument('--server', required=True)
    ap.add_argument('--seed', required=True)
    ap.add_argument('--admin', required=True)
    ap.add_argument('--out', required=True)
    args = ap.parse_args()

    try:
        import cryptography  # noqa: F401  (the provider signs its ID tokens with it)
    except ImportError as e:
        skip('python3-cryptography is not installed (deploy/install-deps.sh): %s' % e)
    with BrowserRun('ves-web-oidc-', args.out) as run:
        from selenium.webdriver.common.by import By
        from selenium.webdriver.support.ui import WebDriverWait
        run.seed(args.seed)
        subprocess.run([args.admin, 'account', 'create', '--db', run.db, '--username', ACCOUNT,
                        '--role', 'supervisor', '--institution', 'north',
                        '--idp-identity', SUBJECT, '--no-password'],
                       check=True, stdin=subprocess.DEVNULL, capture_output=True, text=True)

        http_port = free_loopback_port()
        base = 'http://127.0.0.1:%d' % http_port
        redirect_uri = base + '/api/v1/oidc/callback'
        secret = 'client secret ' + os.urandom(8).hex()
        secret_file = run.path('client-secret')
        with open(secret_file, 'w') as f:
            f.write(secret + '\n')
        idp_log = os.path.join(args.out, 'idp.log')  # the provider appends: this run's only
        if os.path.exists(idp_log):
            os.remove(idp_log)
        idp_script = os.path.join(os.path.dirname(os.path.abspath(__file__)), 'oidc_test_idp.py')
        idp = subprocess.Popen(
            [sys.executable, idp_script, '--port-file', run.path('idp.port'),
             '--log', idp_log, '--client-id', CLIENT_ID,
             '--client-secret', secret, '--redirect-uri', redirect_uri])
        run.add_process(idp)
        idp_base = 'http://127.0.0.1:%s' % wait_file(run.path('idp.port'), idp, 'the IdP')

        def control(settings):
            request = urllib.request.Request(idp_base + '/control',
                                             data=json.dumps(settings).encode(), method='POST',
                                             headers={'Content-Type': 'application/json'})
            with urllib.request.urlopen(request, timeout=10) as r:
                assert r.status == 200

        # The provider shows its own page, as Keycloak or Entra ID do.
        control({'mode': 'good', 'page': True, 'user': {'sub': SUBJECT, 'name': 'Dr Hospital'}})
        run.start_server(args.server, http_listen='127.0.0.1:%d' % http_port, extra_args=[
            '--oidc-issuer', idp_base, '--oidc-client-id', CLIENT_ID,
            '--oidc-client-secret-file', secret_file, '--oidc-redirect-uri', redirect_uri])
        assert run.base == base, (run.base, base)

        driver = run.start_browser('1366,768')
        ready = run.ready
        shot = run.shot

        def signed_in():
            # What the pages ask first: 200 with the account, or 401.
            return driver.execute_async_script(
                'const done = arguments[arguments.length - 1];'
                'fetch("/api/v1/me", {credentials: "same-origin"})'
                '.then(r => done(r.status), e => done(String(e)));')

        def to_provider():
            """From VES's sign-in page to the provider's page, by the button."""
            driver.get(base + '/index.html')
            ready('sign-in')
            button = driver.find_element(By.ID, 'oidc-sign-in')
            WebDriverWait(driver, 30).until(lambda d: button.is_displayed())
            assert button.text == 'Sign in with your hospital account', button.text
            button.click()
            WebDriverWait(driver, 30).until(lambda d: d.current_url.startswith(idp_base))
            assert driver.title == 'Test hospital sign-in', driver.title
            return driver.find_element(By.ID, 'idp-continue')

        def refused(name):
            """Back on VES's sign-in page with the sentence, nobody signed in."""
            WebDriverWait(driver, 30).until(lambda d: d.current_url.startswith(base + '/index.html'))
            ready('sign-in')
            error = driver.find_element(By.ID, 'error')
            WebDriverWait(driver, 30).until(lambda d: error.is_displayed())
            assert error.text == IDP_REFUSED, error.text
            assert 'error=idp' in driver.current_url, driver.current_url
            assert signed_in() == 401
            shot(name)

        # The good sign-in, end to end.
        driver.get(base + '/')
        ready('sign-in')
        shot('01-sign-in-offers-the-hospital')
        assert signed_in() == 401
        continue_link = to_provider()
        user = driver.find_element(By.ID, 'idp-user').text
        assert user == 'Signed in at the hospital as Dr Hospital.', user
        shot('02-identity-provider')
        continue_link.click()
        WebDriverWait(driver, 30).until(lambda d: d.current_url == base + '/trainees.html')
        ready('trainees')
        who = driver.find_element(By.ID, 'who').text
        assert who == ACCOUNT + ' (supervisor, north)', who
        names = [c.text for c in driver.find_elements(By.CSS_SELECTOR, '#trainees tbody td')]
        assert 'Trainee t1' in names, names
        assert signed_in() == 200
        shot('03-signed-in-through-the-hospital')
        driver.find_element(By.ID, 'sign-out').click()
        WebDriverWait(driver, 30).until(lambda d: d.current_url.endswith('/index.html'))
        assert signed_in() == 401

        # The provider's answer carrying another state than VES sent (a forged
        # or crossed callback): the real code, a state of someone else's.
        continue_link = to_provider()
        answer = urllib.parse.urlsplit(continue_link.get_attribute('href'))
        query = dict(urllib.parse.parse_qsl(answer.query))
        assert query.get('code') and query.get('state'), query
        query['state'] = 'forged-' + query['state'][:8]
        driver.get(urllib.parse.urlunsplit(answer._replace(query=urllib.parse.urlencode(query))))
        refused('04-mismatched-state-refused')

        # An ID token signed by another key than the provider publishes.
        control({'mode': 'forged'})
        to_provider().click()
        refused('05-forged-id-token-refused')

        # The server said why in its log, and wrote none of the ID tokens issued.
        with open(os.path.join(args.out, 'ves-server.log')) as f:
            log = f.read()
        assert log.count('oidc: sign-in from') >= 2, log
        with open(idp_log) as f:
            issued = [line.split(': ', 1)[1].strip() for line in f
                      if line.startswith('issued id_token: ')]
        # The good sign-in's and the forged one's: a crossed state is refused
        # before VES asks for a token.
        assert len(issued) == 2, issued
        assert not any(token in log for token in issued), 'an ID token is in the server log'
        print('web_oidc_browser_test: hospital sign-in and its refusals checked; screenshots in ' +
              args.out)
        return 0


if __name__ == '__main__':
    sys.exit(main())
