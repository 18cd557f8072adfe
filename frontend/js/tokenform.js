// The form that asks for the API token when the server protects its reads (MGRAO_PROTECT_READS):
// the #token-ask section of index.html, shown by api.js on a refused read (401), never window.prompt.

const NEEDED = 'This server shows its data only with its API token (MGRAO_API_TOKEN). It is kept in this tab until you close it.';
const REFUSED = 'The server refused that token. Check it and enter it again.';

/**
 * Show the form and resolve with the token entered (trimmed, not empty); `refused` says a token was
 * just refused. Focus moves to the input and back to where it was once the form is sent.
 */
export function askForToken(refused) {
  const section = document.getElementById('token-ask');
  const form = document.getElementById('token-ask-form');
  const input = document.getElementById('token-ask-input');
  const message = document.getElementById('token-ask-message');
  const before = document.activeElement;
  section.classList.toggle('refused', refused);
  message.textContent = refused ? REFUSED : NEEDED;
  input.value = '';
  if (refused) input.setAttribute('aria-invalid', 'true');
  else input.removeAttribute('aria-invalid');
  section.hidden = false;
  input.focus();
  return new Promise((resolve) => {
    function submitted(ev) {
      ev.preventDefault();
      const token = input.value.trim();
      if (!token) {
        input.focus();
        return;
      }
      form.removeEventListener('submit', submitted);
      input.value = '';
      input.removeAttribute('aria-invalid');
      section.hidden = true;
      message.textContent = '';
      if (before && before !== document.body && before.isConnected && typeof before.focus === 'function') before.focus();
      resolve(token);
    }
    form.addEventListener('submit', submitted);
  });
}
