#!/usr/bin/env python3
"""A small OpenID Connect identity provider on loopback for tests/server/oidc_test.cc.

Serves the discovery document, a JWKS with one RSA key, /authorize (signs the
configured user in and sends the browser back with a code: at once, or after
its own sign-in page when "page" is set, for a browser test) and /token
(checks the client secret, the redirect URI and the PKCE S256 verifier, once
per code, and answers an RS256 ID token). POST /control sets the user and how
the next ID token is spoiled, to test that the server refuses it:

  mode: good | forged (signed by another key) | wrong_nonce | wrong_aud |
        wrong_iss | expired | alg_none | hs256
  page: true | false (default): /authorize shows a page naming the user with
        a "Continue" link (id "idp-continue") back to the redirect URI

Standard library plus python3-cryptography (Debian; deploy/install-deps.sh).
Writes its port to --port-file once listening; every request's method and
path, and the token request's form field names, go to --log.
"""
import argparse
import base64
import hashlib
import html
import json
import secrets
import sys
import threading
import time
import urllib.parse
from http.server import BaseHTTPRequestHandler, ThreadingHTTPServer

from cryptography.hazmat.primitives import hashes, hmac
from cryptography.hazmat.primitives.asymmetric import padding, rsa


def b64url(data):
    return base64.urlsafe_b64encode(data).rstrip(b"=").decode()


def int_b64url(n):
    return b64url(n.to_bytes((n.bit_length() + 7) // 8, "big"))


class Idp:
    def __init__(self, client_id, client_secret, redirect_uri):
        self.client_id = client_id
        self.client_secret = client_secret
        self.redirect_uri = redirect_uri
        self.key = rsa.generate_private_key(public_exponent=65537, key_size=2048)
        self.other_key = rsa.generate_private_key(public_exponent=65537, key_size=2048)
        self.kid = "test-key-1"
        self.issuer = ""
        self.user = {"sub": "idp-user-1", "email": "", "email_verified": False, "name": "Dr Test"}
        self.mode = "good"
        self.page = False
        self.codes = {}
        self.lock = threading.Lock()

    def jwks(self):
        pub = self.key.public_key().public_numbers()
        return {"keys": [{"kty": "RSA", "use": "sig", "alg": "RS256", "kid": self.kid,
                          "n": int_b64url(pub.n), "e": int_b64url(pub.e)}]}

    def id_token(self, nonce):
        now = int(time.time())
        claims = {"iss": self.issuer, "aud": self.client_id, "sub": self.user["sub"],
                  "iat": now, "exp": now + 300, "nonce": nonce, "name": self.user["name"]}
        if self.user.get("email"):
            claims["email"] = self.user["email"]
            claims["email_verified"] = bool(self.user.get("email_verified"))
        header = {"alg": "RS256", "typ": "JWT", "kid": self.kid}
        mode = self.mode
        if mode == "wrong_nonce":
            claims["nonce"] = "not-" + nonce
        elif mode == "wrong_aud":
            claims["aud"] = "another-client"
        elif mode == "wrong_iss":
            claims["iss"] = self.issuer + "/other"
        elif mode == "expired":
            claims["iat"], claims["exp"] = now - 3600, now - 600
        elif mode == "alg_none":
            header["alg"] = "none"
        elif mode == "hs256":
            header["alg"] = "HS256"
        signing_input = (b64url(json.dumps(header).encode()) + "." +
                         b64url(json.dumps(claims).encode())).encode()
        if mode == "alg_none":
            return signing_input.decode() + "."
        if mode == "hs256":
            # The classic confusion: HMAC keyed with the public key's numbers.
            h = hmac.HMAC(int_b64url(self.key.public_key().public_numbers().n).encode(),
                          hashes.SHA256())
            h.update(signing_input)
            return signing_input.decode() + "." + b64url(h.finalize())
        key = self.other_key if mode == "forged" else self.key
        signature = key.sign(signing_input, padding.PKCS1v15(), hashes.SHA256())
        return signing_input.decode() + "." + b64url(signature)


def make_handler(idp, log):
    class Handler(BaseHTTPRequestHandler):
        def log_message(self, fmt, *args):
            pass

        def reply(self, status, body, headers=(), content_type="application/json"):
            data = json.dumps(body).encode() if not isinstance(body, bytes) else body
            self.send_response(status)
            self.send_header("Content-Type", content_type)
            self.send_header("Content-Length", str(len(data)))
            for name, value in headers:
                self.send_header(name, value)
            self.end_headers()
            self.wfile.write(data)

        def do_GET(self):
            url = urllib.parse.urlsplit(self.path)
            query = dict(urllib.parse.parse_qsl(url.query))
            log.write(f"GET {url.path}\n")
            log.flush()
            if url.path == "/.well-known/openid-configuration":
                base = idp.issuer
                return self.reply(200, {
                    "issuer": base, "authorization_endpoint": base + "/authorize",
                    "token_endpoint": base + "/token", "jwks_uri": base + "/jwks",
                    "response_types_supported": ["code"],
                    "id_token_signing_alg_values_supported": ["RS256"],
                    "code_challenge_methods_supported": ["S256"]})
            if url.path == "/jwks":
                return self.reply(200, idp.jwks())
            if url.path == "/authorize":
                problems = []
                if query.get("response_type") != "code":
                    problems.append("response_type")
                if query.get("client_id") != idp.client_id:
                    problems.append("client_id")
                if query.get("redirect_uri") != idp.redirect_uri:
                    problems.append("redirect_uri")
                if query.get("code_challenge_method") != "S256" or not query.get("code_challenge"):
                    problems.append("code_challenge")
                if "openid" not in query.get("scope", "").split():
                    problems.append("scope")
                if not query.get("state") or not query.get("nonce"):
                    problems.append("state/nonce")
                if problems:
                    return self.reply(400, {"error": "invalid_request", "fields": problems})
                code = secrets.token_urlsafe(24)
                with idp.lock:
                    idp.codes[code] = (query["code_challenge"], query["nonce"])
                location = idp.redirect_uri + "?" + urllib.parse.urlencode(
                    {"code": code, "state": query["state"]})
                if idp.page:
                    name = html.escape(idp.user["name"])
                    page = ("<!DOCTYPE html><html lang=\"en\"><head><meta charset=\"utf-8\">"
                            "<title>Test hospital sign-in</title></head><body>"
                            "<h1>Test hospital sign-in</h1>"
                            f"<p id=\"idp-user\">Signed in at the hospital as {name}.</p>"
                            f"<p><a id=\"idp-continue\" href=\"{html.escape(location)}\">"
                            "Continue</a></p></body></html>")
                    return self.reply(200, page.encode(), content_type="text/html; charset=utf-8")
                return self.reply(302, b"", [("Location", location)])
            return self.reply(404, {"error": "not_found"})

        def do_POST(self):
            url = urllib.parse.urlsplit(self.path)
            length = int(self.headers.get("Content-Length", "0"))
            body = self.rfile.read(length).decode()
            log.write(f"POST {url.path}\n")
            if url.path == "/control":
                settings = json.loads(body)
                idp.mode = settings.get("mode", idp.mode)
                idp.page = bool(settings.get("page", idp.page))
                idp.user.update(settings.get("user", {}))
                log.flush()
                return self.reply(200, {"ok": True})
            if url.path != "/token":
                log.flush()
                return self.reply(404, {"error": "not_found"})
            form = dict(urllib.parse.parse_qsl(body))
            log.write("token fields: " + ",".join(sorted(form)) + "\n")
            log.flush()
            if form.get("client_id") != idp.client_id or \
                    form.get("client_secret") != idp.client_secret:
                return self.reply(401, {"error": "invalid_client"})
            if form.get("grant_type") != "authorization_code" or \
                    form.get("redirect_uri") != idp.redirect_uri:
                return self.reply(400, {"error": "invalid_request"})
            with idp.lock:
                entry = idp.codes.pop(form.get("code", ""), None)
            if entry is None:
                return self.reply(400, {"error": "invalid_grant"})
            challenge, nonce = entry
            verifier = form.get("code_verifier", "")
            if b64url(hashlib.sha256(verifier.encode()).digest()) != challenge:
                return self.reply(400, {"error": "invalid_grant", "why": "pkce"})
            id_token = idp.id_token(nonce)
            # The test checks that none of these reaches the server's log.
            log.write(f"issued id_token: {id_token}\n")
            log.flush()
            return self.reply(200, {"access_token": secrets.token_urlsafe(24),
                                    "token_type": "Bearer", "expires_in": 300,
                                    "id_token": id_token})
    return Handler


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--port-file", required=True)
    parser.add_argument("--log", required=True)
    parser.add_argument("--client-id", required=True)
    parser.add_argument("--client-secret", required=True)
    parser.add_argument("--redirect-uri", required=True)
    args = parser.parse_args()
    idp = Idp(args.client_id, args.client_secret, args.redirect_uri)
    log = open(args.log, "a", buffering=1)
    server = ThreadingHTTPServer(("127.0.0.1", 0), make_handler(idp, log))
    port = server.server_address[1]
    idp.issuer = f"http://127.0.0.1:{port}"
    with open(args.port_file + ".tmp", "w") as f:
        f.write(f"{port}\n")
    import os
    os.rename(args.port_file + ".tmp", args.port_file)
    try:
        server.serve_forever()
    except KeyboardInterrupt:
        pass
    return 0


if __name__ == "__main__":
    sys.exit(main())
