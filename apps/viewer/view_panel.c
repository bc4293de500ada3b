/* view_panel.c — the parameter panel, generated from the parameter tables (view_param.h): one
 * expander per section and layer, one row per key with a widget by type (entry for numbers,
 * vectors, lists and text; check button for booleans; drop-down for enums), the unit, the range
 * and the doc string as tooltip, a reset-to-default button, and a search box that filters the
 * rows by key. A value is applied when entered: refused with the CLI's message (shown under the
 * search box, the widget keeps the old value), live keys at once, rebuild keys after a
 * confirmation (the scene restarts). A new phenomenon's table gives its panel with no code here. */
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "view.h"
#include "view_param.h"

typedef struct panel_row {
    viewer *v;
    char full_key[200];
    const sq_param *p;
    bool live;         /* sq_param_live: applies at once, else rebuilds (asks first) */
    GtkWidget *row, *widget;
    char pending[600]; /* value waiting for the rebuild confirmation */
} panel_row;

static void row_show_value(panel_row *r);

static void set_status(viewer *v, const char *msg, bool error)
{
    if (!v->panel_status) return;
    gtk_label_set_text(GTK_LABEL(v->panel_status), msg);
    if (error)
        gtk_widget_add_css_class(v->panel_status, "squall-error");
    else
        gtk_widget_remove_css_class(v->panel_status, "squall-error");
}

/* Applies now (live keys, scripts) or after the user confirms (rebuild keys). */
static void apply_value(panel_row *r, const char *value)
{
    view_change how = VIEW_CHANGE_LIVE;
    const sq_result res = view_param_apply(r->v, r->full_key, value, &how);
    char msg[800];
    if (res != SQ_OK) {
        const char *e = sq_last_error();
        snprintf(msg, sizeof msg, "%s", e && *e ? e : sq_result_name(res));
        set_status(r->v, msg, true);
        row_show_value(r); /* refused: the widget shows the scene's value again */
        return;
    }
    if (how == VIEW_CHANGE_PENDING) return; /* view_param_poll shows the outcome */
    snprintf(msg, sizeof msg, "%s = %s%s", r->full_key, value,
             how == VIEW_CHANGE_REBUILT ? " (scene restarted)" : " (live)");
    set_status(r->v, msg, false);
    view_panel_refresh(r->v);
}

void view_panel_status(viewer *v, const char *msg, bool error) { set_status(v, msg, error); }

static void on_confirm(GtkDialog *d, int response, gpointer user)
{
    panel_row *r = (panel_row *)user;
    gtk_window_destroy(GTK_WINDOW(d));
    if (response == GTK_RESPONSE_OK)
        apply_value(r, r->pending);
    else
        row_show_value(r);
}

static void request_value(panel_row *r, const char *value)
{
    if (r->live || !r->v->window) {
        apply_value(r, value);
        return;
    }
    snprintf(r->pending, sizeof r->pending, "%s", value);
    GtkWidget *d = gtk_message_dialog_new(GTK_WINDOW(r->v->window), GTK_DIALOG_MODAL,
                                          GTK_MESSAGE_QUESTION, GTK_BUTTONS_OK_CANCEL,
                                          "%s = %s needs a rebuild: the scene restarts from "
                                          "time 0. Apply?",
                                          r->full_key, value);
    g_signal_connect(d, "response", G_CALLBACK(on_confirm), r);
    gtk_window_present(GTK_WINDOW(d));
}

static void current_or_default(panel_row *r, char *buf, size_t size)
{
    const char *dot = r->full_key + strlen(r->full_key) - strlen(r->p->key) - 1;
    char section[200];
    snprintf(section, sizeof section, "%.*s", (int)(dot - r->full_key), r->full_key);
    view_param_current(r->v, section, r->p->key, buf, size);
    if (!buf[0]) view_param_default(r->p, buf, size);
}

static void row_show_value(panel_row *r)
{
    char val[600];
    current_or_default(r, val, sizeof val);
    r->v->panel_updating = true;
    if (r->p->type == SQ_PARAM_BOOL) {
        const bool on = strcmp(val, "true") == 0 || strcmp(val, "yes") == 0 || strcmp(val, "1") == 0;
        gtk_check_button_set_active(GTK_CHECK_BUTTON(r->widget), on);
    } else if (r->p->type == SQ_PARAM_ENUM) {
        const char *c = r->p->choices;
        guint i = 0, sel = 0;
        while (c && *c) {
            const char *bar = strchr(c, '|');
            const size_t len = bar ? (size_t)(bar - c) : strlen(c);
            if (strlen(val) == len && strncmp(val, c, len) == 0) sel = i;
            i++;
            c = bar ? bar + 1 : NULL;
        }
        gtk_drop_down_set_selected(GTK_DROP_DOWN(r->widget), sel);
    } else {
        gtk_editable_set_text(GTK_EDITABLE(r->widget), val);
    }
    r->v->panel_updating = false;
}

static void on_entry(GtkEntry *e, gpointer user)
{
    panel_row *r = (panel_row *)user;
    request_value(r, gtk_editable_get_text(GTK_EDITABLE(e)));
}

static void on_toggle(GtkCheckButton *b, gpointer user)
{
    panel_row *r = (panel_row *)user;
    if (r->v->panel_updating) return;
    request_value(r, gtk_check_button_get_active(b) ? "true" : "false");
}

static void on_choice(GObject *o, GParamSpec *ps, gpointer user)
{
    (void)ps;
    panel_row *r = (panel_row *)user;
    if (r->v->panel_updating) return;
    GtkStringObject *s = GTK_STRING_OBJECT(gtk_drop_down_get_selected_item(GTK_DROP_DOWN(o)));
    if (s) request_value(r, gtk_string_object_get_string(s));
}

static void on_reset(GtkButton *b, gpointer user)
{
    (void)b;
    panel_row *r = (panel_row *)user;
    char def[600];
    view_param_default(r->p, def, sizeof def);
    request_value(r, def);
}

static GtkWidget *make_widget(panel_row *r)
{
    const sq_param *p = r->p;
    if (p->type == SQ_PARAM_BOOL) {
        GtkWidget *w = gtk_check_button_new();
        g_signal_connect(w, "toggled", G_CALLBACK(on_toggle), r);
        return w;
    }
    if (p->type == SQ_PARAM_ENUM) {
        char buf[512];
        snprintf(buf, sizeof buf, "%s", p->choices ? p->choices : "");
        const char *items[32];
        int n = 0;
        for (char *save = NULL, *t = strtok_r(buf, "|", &save); t && n < 31;
             t = strtok_r(NULL, "|", &save))
            items[n++] = t;
        items[n] = NULL;
        GtkWidget *w = gtk_drop_down_new_from_strings(items);
        g_signal_connect(w, "notify::selected", G_CALLBACK(on_choice), r);
        return w;
    }
    GtkWidget *w = gtk_entry_new();
    gtk_editable_set_width_chars(GTK_EDITABLE(w), 12);
    g_signal_connect(w, "activate", G_CALLBACK(on_entry), r);
    return w;
}

static void tooltip_of(const sq_param *p, bool live, char *buf, size_t size)
{
    char def[300];
    view_param_default(p, def, sizeof def);
    const char *unit = p->unit && *p->unit && strcmp(p->unit, "1") != 0 ? p->unit : "";
    size_t n = (size_t)snprintf(buf, size, "%s\n\ndefault %s %s", p->doc ? p->doc : "", def, unit);
    const bool numeric = p->type == SQ_PARAM_FLOAT || p->type == SQ_PARAM_DOUBLE ||
                         p->type == SQ_PARAM_INT || p->type == SQ_PARAM_VEC3 ||
                         p->type == SQ_PARAM_FLOATS;
    if (numeric && p->max > p->min && n < size)
        n += (size_t)snprintf(buf + n, size - n, "; range [%g, %g] %s", p->min, p->max, unit);
    if (n < size)
        snprintf(buf + n, size - n, "\n%s",
                 live ? "live: applies at once" : "rebuild: the scene restarts (asks first)");
}

static void add_row(viewer *v, GtkWidget *grid, int y, const char *section, const sq_param *p,
                    const sq_phen_plugin *plugin)
{
    if (v->panel_row_count >= VIEW_MAX_ROWS) return;
    panel_row *r = (panel_row *)calloc(1, sizeof *r);
    if (!r) return;
    v->panel_rows[v->panel_row_count++] = r;
    r->v = v;
    r->p = p;
    r->live = sq_param_live(p, plugin);
    if (snprintf(r->full_key, sizeof r->full_key, "%s.%s", section, p->key) >= (int)sizeof r->full_key)
        return; /* a key this long is not in any table */
    char tip[1200];
    tooltip_of(p, r->live, tip, sizeof tip);
    GtkWidget *label = gtk_label_new(p->key);
    gtk_widget_set_halign(label, GTK_ALIGN_START);
    gtk_widget_set_tooltip_text(label, tip);
    r->widget = make_widget(r);
    gtk_widget_set_tooltip_text(r->widget, tip);
    GtkWidget *unit = gtk_label_new(p->unit && strcmp(p->unit, "1") != 0 ? p->unit : "");
    gtk_widget_set_halign(unit, GTK_ALIGN_START);
    GtkWidget *reset = gtk_button_new_from_icon_name("edit-undo-symbolic");
    gtk_widget_set_tooltip_text(reset, "reset to the default");
    g_signal_connect(reset, "clicked", G_CALLBACK(on_reset), r);
    gtk_grid_attach(GTK_GRID(grid), label, 0, y, 1, 1);
    gtk_grid_attach(GTK_GRID(grid), r->widget, 1, y, 1, 1);
    gtk_grid_attach(GTK_GRID(grid), unit, 2, y, 1, 1);
    gtk_grid_attach(GTK_GRID(grid), reset, 3, y, 1, 1);
    r->row = label; /* rows are filtered by hiding their four cells (see on_search) */
    row_show_value(r);
}

static void on_search(GtkSearchEntry *e, gpointer user)
{
    viewer *v = (viewer *)user;
    const char *q = gtk_editable_get_text(GTK_EDITABLE(e));
    for (int i = 0; i < v->panel_row_count; i++) {
        panel_row *r = (panel_row *)v->panel_rows[i];
        const bool show = !*q || strstr(r->full_key, q) != NULL;
        GtkWidget *grid = gtk_widget_get_parent(r->widget);
        int col, row, w, h;
        gtk_grid_query_child(GTK_GRID(grid), r->widget, &col, &row, &w, &h);
        for (int c = 0; c < 4; c++) {
            GtkWidget *cell = gtk_grid_get_child_at(GTK_GRID(grid), c, row);
            if (cell) gtk_widget_set_visible(cell, show);
        }
    }
}

GtkWidget *view_panel_build(viewer *v)
{
    GtkWidget *box = gtk_box_new(GTK_ORIENTATION_VERTICAL, 4);
    gtk_widget_set_size_request(box, 380, -1);
    GtkWidget *search = gtk_search_entry_new();
    g_signal_connect(search, "search-changed", G_CALLBACK(on_search), v);
    gtk_box_append(GTK_BOX(box), search);
    v->panel_status = gtk_label_new("Enter applies a value; hover a key for its meaning.");
    gtk_label_set_wrap(GTK_LABEL(v->panel_status), TRUE);
    gtk_label_set_xalign(GTK_LABEL(v->panel_status), 0.0f);
    gtk_box_append(GTK_BOX(box), v->panel_status);
    GtkWidget *scroll = gtk_scrolled_window_new();
    gtk_widget_set_vexpand(scroll, TRUE);
    gtk_scrolled_window_set_policy(GTK_SCROLLED_WINDOW(scroll), GTK_POLICY_NEVER,
                                   GTK_POLICY_AUTOMATIC);
    GtkWidget *groups = gtk_box_new(GTK_ORIENTATION_VERTICAL, 2);
    view_group g[VIEW_MAX_GROUPS];
    const int n = view_param_groups(v, g, VIEW_MAX_GROUPS);
    for (int i = 0; i < n; i++) {
        GtkWidget *exp = gtk_expander_new(g[i].title);
        gtk_expander_set_expanded(GTK_EXPANDER(exp), strncmp(g[i].section, "layers.", 7) == 0);
        GtkWidget *grid = gtk_grid_new();
        gtk_grid_set_column_spacing(GTK_GRID(grid), 6);
        gtk_grid_set_row_spacing(GTK_GRID(grid), 2);
        for (size_t k = 0; k < g[i].count; k++) add_row(v, grid, (int)k, g[i].section, &g[i].params[k], g[i].plugin);
        gtk_expander_set_child(GTK_EXPANDER(exp), grid);
        gtk_box_append(GTK_BOX(groups), exp);
    }
    gtk_scrolled_window_set_child(GTK_SCROLLED_WINDOW(scroll), groups);
    gtk_box_append(GTK_BOX(box), scroll);
    return box;
}

void view_panel_refresh(viewer *v)
{
    for (int i = 0; i < v->panel_row_count; i++) row_show_value((panel_row *)v->panel_rows[i]);
}

int view_panel_keys(const viewer *v, const char *section, char *buf, size_t size)
{
    size_t len = 0;
    int n = 0;
    const size_t s = strlen(section);
    for (int i = 0; i < v->panel_row_count && len < size; i++) {
        const panel_row *r = (const panel_row *)v->panel_rows[i];
        if (strncmp(r->full_key, section, s) != 0 || r->full_key[s] != '.') continue;
        len += (size_t)snprintf(buf + len, size - len, "%s %s\n", r->full_key + s + 1,
                                r->live ? "live" : "rebuild");
        n++;
    }
    return n;
}

sq_result view_panel_set(viewer *v, const char *full_key, const char *value, view_change *how)
{
    for (int i = 0; i < v->panel_row_count; i++) {
        panel_row *r = (panel_row *)v->panel_rows[i];
        if (strcmp(r->full_key, full_key) != 0) continue;
        const sq_result res = view_param_apply(v, full_key, value, how);
        if (res == SQ_OK) view_panel_refresh(v);
        return res;
    }
    return sq_set_error(SQ_ERR_NOT_FOUND, "the panel has no key '%s'", full_key);
}

void view_panel_free(viewer *v)
{
    for (int i = 0; i < v->panel_row_count; i++) free(v->panel_rows[i]);
    v->panel_row_count = 0;
}
