!> The flat interface's input design (report sec. VII-VIII): the
!> operator's and the Riccati method's mu and length, optimal, amplitude-
!> limited and equalised inputs, their information and responses.
!>
!> A call's design is in its handle h.  The problem (mlid_api_problem) holds
!> the linear model x' = F x + G u, z = H x: its model part (a linear kind)
!> and its parameters, F(nx,nx), G(nx,nu) and H(ny,nx) among them.  Given by
!> name (mlid_api_values): r(ny,ny) the noise spectral density R, gq(nx,nx)
!> the process noise Gamma Q Gamma' (zero: none), the m unknowns by element
!> name, one a line (mlid_design_unknowns: elements of F, G or H), their
!> weights w(m), and for mlid_design_mu and mlid_design_length the state-limit
!> penalty kx(nx,nx) of report 7.6 (symmetric >= 0; not given: none).  A
!> call's own values are its arguments; nu and m, where given, size its
!> outputs and must be the model's inputs and the unknowns.
!> Conventions: mlid_api_deck's comment.
module mlid_api_design
  use, intrinsic :: iso_c_binding, only: c_double, c_int, c_int64_t
  use, intrinsic :: ieee_arithmetic, only: ieee_is_finite
  use mlid_kinds, only: wp, MLID_OK, MLID_ERR_INPUT
  use mlid_handles, only: session_t, handle_session
  use mlid_named, only: named_t
  use mlid_problem, only: problem_needs, PART_MODEL, PART_PARAMS
  use mlid_model_factory, only: MODEL_LINEAR
  use mlid_layout, only: layout_table_t, layout_of
  use mlid_design_unknowns, only: unknown_entries, unknown_blocks
  use mlid_text, only: name_lines, join_lines
  use mlid_design, only: design_t, design_create, operator_mu, riccati_length, transition_length, &
                         costate_input, input_information, mu_for_length, &
                         amplitude_limited_input, equalised_input
  use mlid_design, only: design_state_penalty, input_response, RICCATI_BRACKET
  use mlid_input_ranking, only: ranking_options_t, ranking_t, rank_candidates
  implicit none
  private
  public :: mlid_design_mu, mlid_design_length, mlid_design_input, mlid_design_information, &
            mlid_design_amplitude, mlid_design_mu_for_length, mlid_design_response, &
            mlid_design_equalised, mlid_design_check, mlid_design_rank

  !> The design a handle holds (the module's comment); kx zero when not given.
  type :: given_t
    real(wp), allocatable :: f(:, :), g(:, :), h(:, :), r(:, :), gq(:, :), w(:), kx(:, :)
    integer, allocatable :: ukind(:), urow(:), ucol(:)
  end type given_t

contains

  !> mu_max on [0, T] by the operator method on ncell and 2 ncell cells; u:
  !> the optimal input on the 2 ncell cells (unit energy, nu per cell).  With
  !> the state penalty kx, mu is the largest eigenvalue of tr(WM) - int x' K x dt.
  subroutine mlid_design_mu(h, t, ncell, nu, mu, u, status, msg)
    integer(c_int64_t), intent(in) :: h
    real(c_double), intent(in) :: t
    integer(c_int), intent(in) :: ncell, nu
    real(c_double), intent(out) :: mu, u(2*ncell*nu)
    integer(c_int), intent(out) :: status
    character(len=256), intent(out) :: msg
    type(design_t) :: d
    logical :: penalised
    mu = 0.0_wp
    u = 0.0_wp
    call given_design(h, d, status, msg, nu=nu, penalised=penalised)
    if (status == MLID_OK) call operator_mu(d, t, ncell, mu, u, status, msg)
    if (status /= MLID_OK .and. mu <= 0.0_wp .and. penalised .and. &
        index(msg, 'do not affect') > 0) then
      msg = 'the state penalty outweighs the information of every input: lower its weight'
    end if
  end subroutine mlid_design_mu

  !> The critical length T of mu (method 1 Riccati, 2 transition matrix),
  !> searched up to tmax; lam0(na), na = (m+1) nx: the costate lambda(0)
  !> (transition method only); with the state penalty kx as mlid_design_mu.
  subroutine mlid_design_length(h, mu, tmax, method, na, t, lam0, status, msg)
    integer(c_int64_t), intent(in) :: h
    real(c_double), intent(in) :: mu, tmax
    integer(c_int), intent(in) :: method, na
    real(c_double), intent(out) :: t, lam0(na)
    integer(c_int), intent(out) :: status
    character(len=256), intent(out) :: msg
    type(design_t) :: d
    logical :: penalised
    t = 0.0_wp
    lam0 = 0.0_wp
    call given_design(h, d, status, msg, penalised=penalised, na=na)
    if (status /= MLID_OK) return
    if (method == 1) then
      call riccati_length(d, mu, tmax, t, status, msg)
    else if (method == 2) then
      call transition_length(d, mu, tmax, t, lam0, status, msg)
    else
      status = MLID_ERR_INPUT
      msg = 'method must be 1 (Riccati) or 2 (transition matrix)'
    end if
  end subroutine mlid_design_length

  !> The optimal input from the costate lam0 (transition method) on ncell
  !> cells of [0, T], unit energy (nu per cell).
  subroutine mlid_design_input(h, mu, t, na, lam0, ncell, nu, u, status, msg)
    integer(c_int64_t), intent(in) :: h
    real(c_double), intent(in) :: mu, t, lam0(na)
    integer(c_int), intent(in) :: na, ncell, nu
    real(c_double), intent(out) :: u(ncell*nu)
    integer(c_int), intent(out) :: status
    character(len=256), intent(out) :: msg
    type(design_t) :: d
    u = 0.0_wp
    call given_design(h, d, status, msg, nu=nu, na=na)
    if (status /= MLID_OK) return
    call costate_input(d, mu, t, lam0, ncell, u, status, msg)
  end subroutine mlid_design_input

  !> The information matrix mm(m, m) (unweighted, eq. 7.12) of the input u
  !> held over ncell cells of [0, T] (nu per cell).
  subroutine mlid_design_information(h, t, ncell, nu, u, m, mm, status, msg)
    integer(c_int64_t), intent(in) :: h
    real(c_double), intent(in) :: t, u(ncell*nu)
    integer(c_int), intent(in) :: ncell, nu, m
    real(c_double), intent(out) :: mm(m, m)
    integer(c_int), intent(out) :: status
    character(len=256), intent(out) :: msg
    type(design_t) :: d
    mm = 0.0_wp
    if (.not. all(ieee_is_finite(u))) then
      status = MLID_ERR_INPUT
      msg = 'input is not finite'
      return
    end if
    call given_design(h, d, status, msg, nu=nu, m=m, unweighted=.true.)
    if (status == MLID_OK) call input_information(d, t, ncell, u, mm, status, msg)
  end subroutine mlid_design_information

  !> The best square wave |u| = peak held over ncell cells of [0, T]
  !> (mlid_design amplitude_limited_input, nu per cell); trwm its weighted trace.
  subroutine mlid_design_amplitude(h, t, ncell, peak, nu, u, trwm, status, msg)
    integer(c_int64_t), intent(in) :: h
    real(c_double), intent(in) :: t, peak
    integer(c_int), intent(in) :: ncell, nu
    real(c_double), intent(out) :: u(ncell*nu), trwm
    integer(c_int), intent(out) :: status
    character(len=256), intent(out) :: msg
    type(design_t) :: d
    u = 0.0_wp
    trwm = 0.0_wp
    call given_design(h, d, status, msg, nu=nu)
    if (status == MLID_OK) call amplitude_limited_input(d, t, ncell, peak, u, trwm, status, msg)
  end subroutine mlid_design_amplitude

  !> mu_max for the length td by the secant iteration of eq. 7.89 on the
  !> Riccati critical length, started within RICCATI_BRACKET of mu0 (the operator's).
  subroutine mlid_design_mu_for_length(h, td, mu0, mu, status, msg)
    integer(c_int64_t), intent(in) :: h
    real(c_double), intent(in) :: td, mu0
    real(c_double), intent(out) :: mu
    integer(c_int), intent(out) :: status
    character(len=256), intent(out) :: msg
    type(design_t) :: d
    mu = 0.0_wp
    call given_design(h, d, status, msg)
    if (status == MLID_OK) call mu_for_length(d, td, (1.0_wp - RICCATI_BRACKET)*mu0, &
                                              (1.0_wp + RICCATI_BRACKET)*mu0, mu, status, msg)
  end subroutine mlid_design_mu_for_length

  !> The states x(nx, 0:ncell ns) of x' = F x + G u, x(0) = 0, under the input
  !> u held over ncell cells of [0, T], at ns substeps per cell.  F and G its
  !> own: a response needs no design.
  subroutine mlid_design_response(nx, nu, f, g, t, ncell, ns, u, x, status, msg)
    integer(c_int), intent(in) :: nx, nu, ncell, ns
    real(c_double), intent(in) :: f(nx, nx), g(nx, nu), t, u(ncell*nu)
    real(c_double), intent(out) :: x(nx, ncell*ns + 1)
    integer(c_int), intent(out) :: status
    character(len=256), intent(out) :: msg
    x = 0.0_wp
    if (.not. (all(ieee_is_finite(u)) .and. all(ieee_is_finite(f)) .and. &
               all(ieee_is_finite(g)))) then
      status = MLID_ERR_INPUT
      msg = 'F, G and the input must be finite'
      return
    end if
    call input_response(f, g, t, ncell, ns, u, x, status, msg)
  end subroutine mlid_design_response

  !> The weighted-trace design of report 7.8 (mlid_design equalised_input):
  !> from the weights w, at most iterations updates of eq. 7.88 from step
  !> alpha, the input on 2 ncell cells of [0, T] of energy e.  Results by
  !> name (mlid_api_deck's mlid_values, 'call'): w the weights kept, u the
  !> input (nu per cell), mu, mm its unweighted information (m x m), ratios
  !> the diag(WM) max/min of each design kept.
  subroutine mlid_design_equalised(h, t, ncell, e, iterations, alpha, status, msg)
    integer(c_int64_t), intent(in) :: h
    real(c_double), intent(in) :: t, e, alpha
    integer(c_int), intent(in) :: ncell, iterations
    integer(c_int), intent(out) :: status
    character(len=256), intent(out) :: msg
    type(session_t), pointer :: s
    type(given_t) :: gv
    real(wp), allocatable :: w(:), u(:), mm(:, :), ratios(:)
    real(wp) :: mu
    integer :: m, nu, nratio, stat

    call given_problem(h, s, gv, status, msg)
    if (status /= MLID_OK) return
    s%results = named_t()
    m = size(gv%ukind)
    nu = size(gv%g, 2)
    ! u and ratios are sized by the caller's ncell and iterations, as f2py
    ! sized them before: sizes past the integer range or the memory refused
    status = MLID_ERR_INPUT
    if (ncell < 0 .or. iterations < 0 .or. 2_c_int64_t*ncell*nu > huge(1) .or. &
        iterations == huge(1)) then
      msg = 'cells and iterations must be >= 0 and within the integer range'
      return
    end if
    allocate (w(m), u(2*ncell*nu), mm(m, m), ratios(iterations + 1), stat=stat)
    if (stat /= 0) then
      msg = 'not enough memory for the equalised design''s cells and iterations'
      return
    end if
    call equalised_input(gv%f, gv%g, gv%h, gv%r, gv%gq, gv%ukind, gv%urow, gv%ucol, gv%w, t, &
                         ncell, e, iterations, alpha, w, u, mu, mm, ratios, nratio, status, msg)
    if (status /= MLID_OK) return
    call s%results%put('w', w)
    call s%results%put('u', u)
    call s%results%put('mu', mu)
    call s%results%put('mm', mm)
    call s%results%put('ratios', ratios(1:nratio))
  end subroutine mlid_design_equalised

  !> "Which input to fly" (mlid_input_ranking): the candidates, one a line
  !> by name 'candidates', on ncell cells of [0, T], each scaled to level,
  !> the common energy or peak ('compare'), ranked by 'rank_by'; 'f_band'
  !> (2, Hz) and 'pulse_width' (s), 0 for the model's.  'optimal' is the
  !> operator method's input on ncell/2 and ncell cells (ncell even).
  !> Results by name ('call'): names and signals (one a line), order, u
  !> (ncell nu, candidates), mm (m, m candidates), det, trace, sigma (m,
  !> candidates), energy, peak, x_peak, x_rms (nx, candidates), y_peak,
  !> y_rms (ny, candidates).
  subroutine mlid_design_rank(h, t, ncell, level, status, msg)
    integer(c_int64_t), intent(in) :: h
    real(c_double), intent(in) :: t, level
    integer(c_int), intent(in) :: ncell
    integer(c_int), intent(out) :: status
    character(len=256), intent(out) :: msg
    type(session_t), pointer :: s
    type(given_t) :: gv
    type(design_t) :: d
    type(ranking_options_t) :: o
    type(ranking_t) :: r
    real(wp), allocatable :: uopt(:)
    real(wp) :: mu

    call given_problem(h, s, gv, status, msg)
    if (status == MLID_OK) call ranking_options(s, o, status, msg)
    if (status /= MLID_OK) return
    status = MLID_ERR_INPUT
    if (ncell < 4 .or. mod(ncell, 2) /= 0 .or. ncell > 100000) then
      msg = 'cells must be even, 4 to 100000 (the optimal input''s grids are cells/2 and cells)'
      return
    end if
    call design_create(gv%f, gv%g, gv%h, gv%r, gv%ukind, gv%urow, gv%ucol, gv%w, d, status, msg, &
                       gv%gq)
    if (status /= MLID_OK) return
    allocate (uopt(ncell*d%nu))
    uopt = 0.0_wp
    if (any(o%names == 'optimal')) call operator_mu(d, t, ncell/2, mu, uopt, status, msg)
    if (status == MLID_OK) call rank_candidates(d, gv%f, gv%g, gv%h, gv%f, t, ncell, o, level, &
                                                uopt, r, status, msg)
    if (status /= MLID_OK) return
    s%results = named_t()
    call s%results%put('names', join_lines(r%names))
    call s%results%put('signals', join_lines(r%detail))
    call s%results%put('order', r%order)
    call s%results%put('u', r%u)
    call s%results%put('mm', reshape(r%mm, [d%m, d%m*size(r%names)]))
    call s%results%put('det', r%det)
    call s%results%put('trace', r%trace)
    call s%results%put('sigma', r%sigma)
    call s%results%put('energy', r%energy)
    call s%results%put('peak', r%peak)
    call s%results%put('x_peak', r%x_peak)
    call s%results%put('x_rms', r%x_rms)
    call s%results%put('y_peak', r%y_peak)
    call s%results%put('y_rms', r%y_rms)
  end subroutine mlid_design_rank

  !> The ranking's options as given by name in session s (mlid_design_rank).
  subroutine ranking_options(s, o, status, msg)
    type(session_t), intent(inout) :: s
    type(ranking_options_t), intent(out) :: o
    integer(c_int), intent(out) :: status
    character(len=256), intent(out) :: msg
    character(len=:), allocatable :: text
    character(len=64), allocatable :: names(:)
    real(wp), allocatable :: band(:)

    call s%given%get('candidates', text, status, msg)
    if (status /= MLID_OK) return
    call name_lines(text, names)
    status = MLID_ERR_INPUT
    if (size(names) == 0 .or. any(len_trim(names) > 16)) then
      msg = 'candidates: give at least one, each a name of at most 16 characters'
      return
    end if
    o%names = names
    status = MLID_OK
    call s%given%get('compare', text, status, msg)
    if (status == MLID_OK) o%compare = text
    if (status == MLID_OK) call s%given%get('rank_by', text, status, msg)
    if (status == MLID_OK) o%rank_by = text
    if (status == MLID_OK) call s%given%get('f_band', band, status, msg, [2])
    if (status == MLID_OK) call s%given%get('pulse_width', o%pulse_width, status, msg)
    if (status /= MLID_OK) return
    o%f_min = band(1)
    o%f_max = band(2)
  end subroutine ranking_options

  !> The design handle h holds, created with its weights (unit weights when
  !> unweighted) and, when penalised is present, penalised by kx when kx is
  !> given and not zero (penalised says so); nu and m checked when present.
  subroutine given_design(h, d, status, msg, nu, m, unweighted, penalised, na)
    integer(c_int64_t), intent(in) :: h
    type(design_t), intent(out) :: d
    integer(c_int), intent(out) :: status
    character(len=256), intent(out) :: msg
    integer(c_int), intent(in), optional :: nu, m
    integer(c_int), intent(in), optional :: na   !< a costate's length lam0, checked
    logical, intent(in), optional :: unweighted
    logical, intent(out), optional :: penalised
    type(session_t), pointer :: s
    type(given_t) :: gv
    logical :: pen

    pen = .false.
    call given_problem(h, s, gv, status, msg, nu, m)
    if (status == MLID_OK) pen = present(penalised) .and. any(gv%kx /= 0.0_wp)
    if (present(penalised)) penalised = pen
    if (status /= MLID_OK) return
    if (present(unweighted)) then
      if (unweighted) gv%w = 1.0_wp
    end if
    call design_create(gv%f, gv%g, gv%h, gv%r, gv%ukind, gv%urow, gv%ucol, gv%w, d, status, msg, &
                       gv%gq)
    if (status == MLID_OK .and. pen) call design_state_penalty(d, gv%kx, status, msg)
    if (status /= MLID_OK .or. .not. present(na)) return
    if (na /= d%na) then
      status = MLID_ERR_INPUT
      write (msg, '(a,i0)') 'lam0 needs (m+1) nx = ', d%na
    end if
  end subroutine given_design

  !> The design in handle h checked as every call above checks it (its
  !> model, unknowns, weights, noise), for a front end to refuse a bad one
  !> when it is made.
  subroutine mlid_design_check(h, status, msg)
    integer(c_int64_t), intent(in) :: h
    integer(c_int), intent(out) :: status
    character(len=256), intent(out) :: msg
    type(session_t), pointer :: s
    type(given_t) :: gv
    call given_problem(h, s, gv, status, msg)
  end subroutine mlid_design_check

  !> The design handle h holds (the module's comment) and its session s: F,
  !> G and H from the problem's linear model, the rest by name (kx zero when
  !> not given); nu and m checked when present.
  subroutine given_problem(h, s, gv, status, msg, nu, m)
    integer(c_int64_t), intent(in) :: h
    type(session_t), pointer, intent(out) :: s
    type(given_t), intent(out) :: gv
    integer(c_int), intent(out) :: status
    character(len=256), intent(out) :: msg
    integer(c_int), intent(in), optional :: nu, m
    type(layout_table_t) :: lt
    character(len=:), allocatable :: unknowns
    character(len=64), allocatable :: names(:)
    integer, allocatable :: idx(:)
    integer :: nun

    call handle_session(h, s, status, msg)
    if (status /= MLID_OK) return
    associate (p => s%problem, given => s%given)
      call problem_needs(p, [PART_MODEL, PART_PARAMS], status, msg)
      if (status /= MLID_OK) return
      if (p%mkind /= MODEL_LINEAR) then
        status = MLID_ERR_INPUT
        msg = 'input design needs a linear model (its F, G and H)'
        return
      end if
      call layout_of(p%mkind, p%nx, p%nu, p%ny, p%nw, p%iconst, p%rconst, lt, status, msg)
      if (status /= MLID_OK) return
      if (size(p%theta) /= lt%nth) then
        status = MLID_ERR_INPUT
        write (msg, '(a,i0,a,i0)') 'the parameters have ', size(p%theta), &
          ' values; the linear model has ', lt%nth
        return
      end if
      if (present(nu)) then
        if (nu /= p%nu) then
          status = MLID_ERR_INPUT
          write (msg, '(a,i0,a,i0,a)') 'nu is ', nu, '; the model has ', p%nu, ' inputs'
          return
        end if
      end if
      gv%f = block(lt, p%theta, 'f')
      gv%g = block(lt, p%theta, 'g')
      gv%h = block(lt, p%theta, 'h')
      call given%get('r', gv%r, status, msg, [p%ny, p%ny])
      call given%get('gq', gv%gq, status, msg, [p%nx, p%nx])
      call given%get('unknowns', unknowns, status, msg)
      if (status /= MLID_OK) return
      call name_lines(unknowns, names)
      call unknown_entries(lt, names, idx, status, msg)
      if (status /= MLID_OK) return
      call unknown_blocks(lt, idx, gv%ukind, gv%urow, gv%ucol, status, msg)
      if (status /= MLID_OK) return
      nun = size(gv%ukind)
      call given%get('w', gv%w, status, msg, [nun])
      if (status /= MLID_OK) return
      if (present(m)) then
        if (m /= nun) then
          status = MLID_ERR_INPUT
          write (msg, '(a,i0,a,i0,a)') 'm is ', m, '; the design has ', nun, ' unknowns'
          return
        end if
      end if
      if (given%find('kx') > 0) then
        call given%get('kx', gv%kx, status, msg, [p%nx, p%nx])
      else
        allocate (gv%kx(p%nx, p%nx))
        gv%kx = 0.0_wp
      end if
    end associate
  end subroutine given_problem

  !> Block key (a matrix) of the linear model's theta, laid out by lt.
  function block(lt, theta, key) result(a)
    type(layout_table_t), intent(in) :: lt
    real(wp), intent(in) :: theta(:)
    character(len=*), intent(in) :: key
    real(wp), allocatable :: a(:, :)
    integer :: b
    b = findloc(lt%key, key, 1)
    a = reshape(theta(lt%off(b) + 1:lt%off(b) + lt%rows(b)*lt%cols(b)), [lt%rows(b), lt%cols(b)])
  end function block

end module mlid_api_design
