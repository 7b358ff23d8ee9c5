// The sign-in page (docs/web.md, "Signing in"): a password, an access token
// or the hospital's identity provider. Loaded after common.js.
'use strict';

// Why a sign-in through the identity provider came back refused
// (/index.html?error=CODE, set by the server's callback).
const kSignInErrors = {
  idp: 'The hospital sign-in did not complete. Try again.',
  no_account: 'Your hospital account is not linked to a VES account. Ask a VES administrator.',
  account: 'Your VES account is revoked or has expired. Ask a VES administrator.',
  unavailable: 'The hospital sign-in is not reachable now. Try again later.',
  busy: 'Too many people are signed in. Try again later.',
};

async function signInPage() {
  const error = param('error');
  if (error) showError(kSignInErrors[error] || 'Sign-in refused.');
  const finish = (reply) => {
    sessionStorage.setItem('ves_csrf', reply.csrf_token);
    location.href = '/trainees.html';
  };
  $('password-form').addEventListener('submit', async (event) => {
    event.preventDefault();
    try {
      finish(await api('sign-in', {method: 'POST', body: JSON.stringify(
          {username: $('username').value.trim().toLowerCase(), password: $('password').value})}));
    } catch (e) {
      $('password').value = '';
      showError(e.message);
    }
  });
  $('sign-in-form').addEventListener('submit', async (event) => {
    event.preventDefault();
    try {
      finish(await api('sign-in', {method: 'POST',
                                   body: JSON.stringify({token: $('token').value})}));
    } catch (e) {
      showError(e.message);
    }
  });
  try {
    const methods = await api('sign-in');
    $('oidc').hidden = !methods.oidc;
  } catch (e) {
    // The sign-in page works without knowing: the forms stay.
  }
}

pages['sign-in'] = signInPage;
